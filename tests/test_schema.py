"""The JSON-lines protocol schema (draft 2020-12): every message the harness sends today and every
reply a correct program gives validate; malformed requests and replies are rejected with the place
of the violation; a violation is never a ValueError (the protocol's refusal)."""

from __future__ import annotations

import json
import math
import sys
import textwrap
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

from tstarg.reports.certification import certify
from tstarg.reports.jsonl import CommandImplementation
from tstarg.reports.jsonl_schema import (
    METHODS,
    SCHEMA_DIR,
    SCHEMA_VERSION,
    ProtocolError,
    check_program,
    load_schema,
    validate_reply,
    validate_request,
)

PROGRAM = Path(__file__).parent / "meta" / "jsonl_program.py"

# A transparent proxy: forwards each request line to the program and each reply line back,
# logging both, so the test sees exactly what crossed the pipe.
PROXY = textwrap.dedent("""
    import subprocess, sys
    log = open(sys.argv[1], "a")
    child = subprocess.Popen(sys.argv[2:], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1)
    for line in sys.stdin:
        log.write("> " + line); log.flush()
        child.stdin.write(line); child.stdin.flush()
        reply = child.stdout.readline()
        log.write("< " + reply); log.flush()
        sys.stdout.write(reply); sys.stdout.flush()
""")


def test_schemas_are_valid_draft_2020_12_and_versioned():
    files = sorted(SCHEMA_DIR.glob("*.schema.json"))
    assert {p.name for p in files} == {
        "request.schema.json",
        "reply.schema.json",
        "certificate.schema.json",
    }
    Draft202012Validator.check_schema(
        json.loads((SCHEMA_DIR / "certificate.schema.json").read_text())
    )
    for p in files:
        if p.name == "certificate.schema.json":
            continue
        schema = json.loads(p.read_text())
        Draft202012Validator.check_schema(schema)
        assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
        assert schema["x-tstarg-protocol-version"] == SCHEMA_VERSION
        assert f":{SCHEMA_VERSION}:" in schema["$id"]


@pytest.fixture(scope="module")
def transcript(tmp_path_factory):
    """The wire traffic of a short certification of tests/meta/jsonl_program.py (all its methods)."""
    log = tmp_path_factory.mktemp("wire") / "log.txt"
    proxy = log.with_name("proxy.py")
    proxy.write_text(PROXY)
    impl = CommandImplementation(
        f"{sys.executable} {proxy} {log} {sys.executable} {PROGRAM}", timeout=30
    )
    try:
        cert = certify(
            impl,
            max_examples=3,
            seed=0,
            target="proxy",
            shrink=False,
            checks=[
                "poisson_tensor.reference",
                "poisson_tensor.degenerate",
                "hamiltonian_vector_field.reference",
                "flow.reference",
            ],
        )
    finally:
        impl.close()
    assert cert.passed, cert.summary()
    lines = log.read_text().splitlines()
    requests = [json.loads(s[2:]) for s in lines if s.startswith("> ")]
    replies = [json.loads(s[2:]) for s in lines if s.startswith("< ")]
    assert len(requests) == len(replies) > 10
    return requests, replies


def test_what_the_harness_sends_and_gets_today_validates(transcript):
    requests, replies = transcript
    methods = {r["id"]: r["method"] for r in requests}
    # the probe asks for every method (and, once the harness asks for it, "capabilities")
    assert (
        {"poisson_tensor", "hamiltonian_vector_field", "flow"}
        <= set(methods.values())
        <= set(METHODS)
    )
    kinds = set()
    for req in requests:
        validate_request(req)
    for rep in replies:
        validate_reply(rep)
        validate_reply(rep, methods[rep["id"]])
        kinds.add("error" if "error" in rep else "result")
        if "error" in rep:
            assert rep["error"].startswith(("ValueError", "unknown method")), rep
    # the program does not provide flow ("unknown method") and refuses the degenerate set (ValueError)
    assert kinds == {"error", "result"}
    gravity = [
        r for r in requests if r["method"] == "hamiltonian_vector_field" and r["args"]["potential"]
    ]
    assert gravity, "the vector-field check draws gravity too"


REQ = {
    "id": 1,
    "method": "poisson_tensor",
    "args": {"f": [[[0.0]]], "theta": [[0.0]], "upsilon": [[0.0]], "x": [0.5], "pi": [1.0]},
}


def _with(doc, path, value):
    doc = json.loads(json.dumps(doc))
    *head, last = path
    d = doc
    for k in head:
        d = d[k]
    if value is _DELETE:
        del d[last]
    else:
        d[last] = value
    return doc


_DELETE = object()


@pytest.mark.parametrize(
    "path, value, where",
    [
        (("id",), _DELETE, "(the message)"),
        (("method",), "poisson", "method"),
        (("args", "x"), _DELETE, "args"),
        (("args", "x"), ["0.5"], "args.x"),
        (("args", "f"), [[0.0]], "args.f"),
        (("args", "theta"), [0.0], "args.theta"),
        (("args", "extra"), 1, "args"),
        (("protocol_version",), "2.0", "protocol_version"),
        (("args",), None, "args"),
    ],
)
def test_malformed_requests_are_rejected(path, value, where):
    validate_request(REQ)
    bad = _with(REQ, path, value)
    with pytest.raises(ProtocolError, match="violates") as info:
        validate_request(bad)
    assert f"at {where}" in str(info.value)


def test_capabilities_request_and_flow_steps():
    validate_request({"id": "c", "method": "capabilities", "args": {}})
    with pytest.raises(ProtocolError):
        validate_request({"id": 2, "method": "capabilities", "args": {"x": 1}})
    flow = {
        "id": 3,
        "method": "flow",
        "args": {
            "f": [[[0.0]]],
            "theta": [[0.0]],
            "upsilon": [[0.0]],
            "inertia": [[2.0]],
            "potential": None,
            "x0": [0.1],
            "pi0": [1.0],
            "t": 0.5,
            "steps": 10,
        },
    }
    validate_request(flow)
    with pytest.raises(ProtocolError, match="steps"):
        validate_request(_with(flow, ("args", "steps"), 0))
    with pytest.raises(ProtocolError, match="potential"):
        validate_request(
            _with(flow, ("args", "potential"), {"kind": "spring", "L": [1.0], "gamma": [1.0]})
        )


CAPS = {
    "protocol_version": "1.0",
    "methods": ["poisson_tensor"],
    "name": "su2-only",
    "algebras": ["su(2)"],
    "theta": True,
    "upsilon": False,
    "gravity": False,
    "batched": False,
    "max_abs_t": 100.0,
}


@pytest.mark.parametrize(
    "reply, method, ok",
    [
        ({"id": 1, "result": [[0.0, 1.0], [-1.0, None]]}, "poisson_tensor", True),
        ({"id": 1, "error": "ValueError: degenerate point"}, "poisson_tensor", True),
        ({"id": 1, "result": [[0.0], [1.0]]}, "flow", True),
        ({"id": 1, "result": [[0.0], [1.0], [2.0]]}, "flow", False),
        ({"id": 1, "result": "nope"}, "poisson_tensor", False),
        ({"id": 1, "result": [[0.0]], "error": "both"}, None, False),
        ({"result": [[0.0]]}, None, False),
        ({"id": 1, "error": ""}, None, False),
        ({"id": 1, "error": 3}, None, False),
        ({"id": 1, "result": CAPS}, "capabilities", True),
        ({"id": 1, "result": {**CAPS, "algebras": "all"}}, "capabilities", True),
        (
            {"id": 1, "result": {k: v for k, v in CAPS.items() if k != "protocol_version"}},
            "capabilities",
            False,
        ),
        ({"id": 1, "result": {**CAPS, "protocol_version": "2.0"}}, "capabilities", False),
        ({"id": 1, "result": {**CAPS, "methods": ["teleport"]}}, "capabilities", False),
        ({"id": 1, "result": {**CAPS, "max_abs_t": -1}}, "capabilities", False),
        ({"id": 1, "result": {**CAPS, "algebras": []}}, "capabilities", False),
        ({"id": 1, "result": {**CAPS, "upsilon": "no"}}, "capabilities", False),
    ],
)
def test_replies(reply, method, ok):
    if ok:
        validate_reply(reply, method)
    else:
        with pytest.raises(ProtocolError):
            validate_reply(reply, method)


def test_violations_are_not_value_errors_and_nan_is_named():
    assert not issubclass(ProtocolError, ValueError)
    with pytest.raises(ProtocolError, match="null"):
        validate_reply({"id": 1, "result": [[math.nan]]}, "poisson_tensor")
    with pytest.raises(ValueError, match="method"):
        validate_reply({"id": 1, "result": 1}, "teleport")
    with pytest.raises(ValueError, match="kind"):
        load_schema("answer")


def test_check_program_finds_violations(tmp_path):
    assert check_program(f"{sys.executable} {PROGRAM}") == []
    bad = tmp_path / "bad.py"
    bad.write_text(
        "import sys, json\nfor line in sys.stdin:\n    r = json.loads(line)\n"
        "    print(json.dumps({'id': r['id'], 'result': 'P', 'error': 'x'}), flush=True)\n"
    )
    problems = check_program(f"{sys.executable} {bad}")
    assert len(problems) == 4 and all("violates" in p for p in problems)


# ------------------------------------------------------------------ one spec (issue 29)
def test_shipped_schemas_are_the_ones_generated_from_the_protocol_spec():
    """reports/schema/*.json are written from tstarg.refimpl.PROTOCOL; a hand edit (or a spec
    change without `python -m tstarg.reports.jsonl_schema --write-schemas`) fails here."""
    from tstarg.reports.jsonl_schema import build_schema

    for kind in ("request", "reply"):
        assert load_schema(kind) == build_schema(kind), f"{kind}.schema.json differs from the spec"


def test_docs_protocol_table_is_the_spec():
    from tstarg.refimpl._protocol import markdown_table

    text = (Path(__file__).parents[1] / "docs" / "protocol.md").read_text()
    a = text.index("-->\n", text.index("<!-- protocol-table")) + 4
    b = text.index("\n<!-- /protocol-table -->")
    assert text[a:b] == markdown_table()


def test_every_consumer_reads_the_spec():
    """The JSON-lines client, the guard, the request enum and the certification's checks all name
    exactly the spec's methods; every spec argument has a sample value."""
    from tstarg.refimpl import PROTOCOL
    from tstarg.reports import _guard, jsonl
    from tstarg.reports.certification import CHECKS
    from tstarg.reports.jsonl_schema import SAMPLE_VALUES

    names = PROTOCOL.method_names
    assert tuple(jsonl.METHODS) == names and METHODS == ("capabilities", *names)
    assert {m: PROTOCOL.by_name[m].arg_names for m in names} == jsonl.METHODS
    assert load_schema("request")["properties"]["method"]["enum"] == list(METHODS)
    assert set(CHECKS.values()) <= set(names)
    from tstarg.reports.certification import REGISTRY
    from tstarg.reports.certification.check import ANY_METHOD

    assert ANY_METHOD == names
    assert all(set(c.needs) <= set(names) for c in REGISTRY.values()), "a non-spec method"
    assert set(names) <= set(CHECKS.values()), "a spec method with no certification check"
    assert all(a.name in SAMPLE_VALUES for m in PROTOCOL.methods for a in m.args)
    attrs = {a.name for a in PROTOCOL.attributes if a.where == "attribute"}
    assert attrs <= set(_guard.ATTRIBUTES)
    caps = load_schema("reply")["$defs"]["result_capabilities"]["properties"]
    assert set(caps) == {"protocol_version", "methods"} | {a.name for a in PROTOCOL.attributes}


def test_implementation_base_class_provides_any_subset():
    """docs/design.md: an implementation provides any subset. A subclass overriding only flow provides
    only flow (the base's methods are placeholders), and the guard exposes only that."""
    from tstarg.refimpl import Implementation, provided_methods, provides
    from tstarg.reports._guard import Guarded

    class FlowOnly(Implementation):
        def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):
            return x0, pi0

    impl = FlowOnly()
    assert provided_methods(impl) == ["flow"] and not provides(impl, "poisson_tensor")
    with pytest.raises(NotImplementedError, match="poisson_tensor"):
        impl.poisson_tensor(None, None, None, None, None)
    g = Guarded(impl)
    assert g.provided == ["flow"] and not hasattr(g, "poisson_tensor")


@pytest.mark.parametrize(
    "attr, value, ok",
    [
        ("flow_tolerance", 1.0, False),  # a flow that never moves would pass
        ("flow_tolerance", 1e-4, True),
        ("flow_tolerance", 0.0, False),
        ("precision_digits", 3, False),
        ("precision_digits", 15.9, True),
        ("precision_digits", float("nan"), False),
        ("order", 2.5, False),
        ("order", True, False),
        ("poisson_integrator", "yes", False),
    ],
)
def test_declared_attributes_are_capped(attr, value, ok):
    """Declared tolerances past the spec's caps are refused by name, before anything runs; the
    JSON-lines capabilities schema carries the same caps."""
    from tstarg.reports._guard import Guarded, NotAnImplementation

    class Impl:
        def poisson_tensor(self, f, theta, upsilon, x, pi):  # pragma: no cover - never called
            raise AssertionError

    impl = Impl()
    setattr(impl, attr, value)
    reply = {"id": 1, "result": {**CAPS, attr: value}}
    if ok:
        Guarded(impl)
        validate_reply(reply, "capabilities")
    else:
        with pytest.raises(NotAnImplementation, match=attr):
            Guarded(impl)
        if not (isinstance(value, float) and math.isnan(value)):
            with pytest.raises(ProtocolError):
                validate_reply(reply, "capabilities")
