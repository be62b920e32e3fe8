"""The JSON-lines protocol of ``tstarg certify --cmd`` as JSON Schema (draft 2020-12), version 1.0.

The schemas are package data beside this module: ``schema/request.schema.json`` and
``schema/reply.schema.json``. An implementer in any language can validate their messages
against them; the harness validates on its side with :func:`validate_request` (what it sends)
and :func:`validate_reply` (what it receives).

Rules the schemas encode:

1. a request is ``{"id", "method", "args"}`` (optionally ``"protocol_version": "1.x"``), with
   ``method`` one of ``capabilities``, ``poisson_tensor``, ``hamiltonian_vector_field``, ``flow``
   and ``args`` holding exactly that method's protocol parameters by name (docs/design.md); arrays
   are nested lists of numbers;
2. a reply is ``{"id", "result"}`` or ``{"id", "error"}`` (never both, nothing else), ``error`` a
   non-empty string; ``"unknown method ..."`` means not provided, ``"ValueError: ..."`` is a
   refusal (degenerate point, or outside the declared domain);
3. results: the Poisson tensor as a ``2n x 2n`` nested list; ``[xdot, pidot]``; ``[x, pi]``;
   ``null`` for a non-finite entry (JSON has no NaN);
4. the ``capabilities`` result declares the domain: ``protocol_version`` and ``methods``
   (required), ``algebras`` (``"all"`` or catalogue names), ``dimensions``, ``theta``,
   ``upsilon``, ``gravity``, ``batched``, ``max_abs_t``, ``negative_t``, ``precision_digits``,
   ``flow_tolerance``, ``order``, ``poisson_integrator``.

A violation raises :class:`ProtocolError`, deliberately *not* a ``ValueError``: in the
protocol a ``ValueError`` is a legitimate refusal, and a malformed reply must never count as one.

``python -m tstarg.reports.jsonl_schema --cmd "PROGRAM ARGS"`` sends a ``capabilities`` request
and one small su(2) request per method to a program and validates every reply.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Any

from jsonschema import Draft202012Validator
from jsonschema.exceptions import best_match

from tstarg.refimpl import PROTOCOL as SPEC

__all__ = [
    "METHODS",
    "SCHEMA_VERSION",
    "ProtocolError",
    "build_schema",
    "load_schema",
    "validate_reply",
    "validate_request",
]

SCHEMA_VERSION = SPEC.version
METHODS = ("capabilities", *SPEC.method_names)
SCHEMA_DIR = Path(__file__).with_name("schema")


class ProtocolError(Exception):
    """A message violates the JSON-lines protocol schema (not a ``ValueError``: see the module docstring)."""


@functools.cache
def load_schema(kind: str) -> dict:
    """The schema ``"request"`` or ``"reply"`` as a dict."""
    if kind not in ("request", "reply"):
        raise ValueError(f"schema kind must be 'request' or 'reply', got {kind!r}")
    return json.loads((SCHEMA_DIR / f"{kind}.schema.json").read_text())


# ------------------------------------------------------------------ the schemas, from the spec
_URN = "urn:tstarg:jsonl:{v}:{kind}"
_PV = {
    "description": "MAJOR.MINOR; a program must accept any 1.x.",
    "type": "string",
    "pattern": "^1\\.[0-9]+$",
}
_ID = {
    "description": "Chosen by the harness (today: 1, 2, 3, ...); the reply repeats it.",
    "type": ["integer", "string"],
}
_REQUEST_DEFS = {
    "vector": {
        "description": "n numbers",
        "type": "array",
        "minItems": 1,
        "items": {"type": "number"},
    },
    "points": {
        "description": "a vector (n,), or (batched programs only) nested lists of them: leading batch axes",
        "anyOf": [
            {"$ref": "#/$defs/vector"},
            {"type": "array", "minItems": 1, "items": {"$ref": "#/$defs/points"}},
        ],
    },
    "matrix": {
        "description": "n x n, row-major: matrix[i][j]",
        "type": "array",
        "minItems": 1,
        "items": {"$ref": "#/$defs/vector"},
    },
    "structure_constants": {
        "description": "f[m][a][b] = f^m_ab, [e_a, e_b] = f^m_ab e_m; n x n x n",
        "type": "array",
        "minItems": 1,
        "items": {"$ref": "#/$defs/matrix"},
    },
    "potential": {
        "description": "null (free motion) or gravity (twee15): V(g) = -(gamma | Ad(g) L)",
        "anyOf": [
            {"type": "null"},
            {
                "type": "object",
                "required": ["kind", "L", "gamma"],
                "additionalProperties": False,
                "properties": {
                    "kind": {"const": "gravity"},
                    "L": {"$ref": "#/$defs/vector"},
                    "gamma": {"$ref": "#/$defs/vector"},
                },
            },
        ],
    },
    "number": {"type": "number"},
    "integer": {"type": "integer", "minimum": 1},
}


def _attribute_schema(a) -> dict:
    kinds: dict[str, dict[str, Any]] = {
        "string": {"type": "string"},
        "boolean": {"type": "boolean"},
        "number": {"type": "number"},
        "integer": {"type": "integer"},
        "number_or_null": {"type": ["number", "null"]},
        "integers": {"type": "array", "minItems": 1, "items": {"type": "integer", "minimum": 1}},
        "algebras": {
            "anyOf": [
                {"const": "all"},
                {
                    "type": "array",
                    "minItems": 1,
                    "uniqueItems": True,
                    "items": {"type": "string", "minLength": 1},
                },
            ]
        },
    }
    out = {"description": a.doc, **kinds[a.type]}
    if a.low is not None:
        out["exclusiveMinimum" if a.low_open else "minimum"] = a.low
    if a.high is not None:
        out["maximum"] = a.high
    return out


def build_schema(kind: str) -> dict:
    """The schema ``"request"`` or ``"reply"`` generated from the protocol spec
    (:data:`tstarg.refimpl._protocol.SPEC`); the shipped files are this, written by
    ``python -m tstarg.reports.jsonl_schema --write-schemas`` (a test compares them)."""
    head = {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": _URN.format(v=SCHEMA_VERSION, kind=kind),
    }
    methods = SPEC.methods
    if kind == "request":
        defs = {"id": _ID, "protocol_version": _PV, **_REQUEST_DEFS}
        defs["args_capabilities"] = {"type": "object", "maxProperties": 0}
        for m in methods:
            props = {a.name: {"$ref": f"#/$defs/{a.kind}"} for a in m.args}
            props |= {
                a.name: {"description": f"optional: {a.doc}", "$ref": f"#/$defs/{a.kind}"}
                for a in m.optional
            }
            defs[f"args_{m.name}"] = {
                "type": "object",
                "required": list(m.arg_names),
                "additionalProperties": False,
                "properties": props,
            }
        return {
            **head,
            "title": f"tstarg JSON-lines protocol {SCHEMA_VERSION}: a request (one JSON object per line on the program's stdin)",
            "description": "The harness (tstarg certify --cmd) sends one request per line and waits for the reply with the same id. Arrays are nested JSON lists of float64 numbers; conventions are those of docs/conventions.md (f[m][a][b] = f^m_ab, z = (x, pi), body momenta). Methods follow the implementation protocol (refimpl/_protocol.py, the spec); 'capabilities' asks the program for its declared domain.",
            "x-tstarg-protocol-version": SCHEMA_VERSION,
            "type": "object",
            "required": ["id", "method", "args"],
            "properties": {
                "id": {"$ref": "#/$defs/id"},
                "method": {"enum": list(METHODS)},
                "args": {"type": "object"},
                "protocol_version": {"$ref": "#/$defs/protocol_version"},
            },
            "additionalProperties": False,
            "allOf": [
                {
                    "if": {"properties": {"method": {"const": name}}},
                    "then": {"properties": {"args": {"$ref": f"#/$defs/args_{name}"}}},
                }
                for name in METHODS
            ],
            "$defs": defs,
        }
    if kind != "reply":
        raise ValueError(f"schema kind must be 'request' or 'reply', got {kind!r}")
    caps = {
        "protocol_version": {"$ref": "#/$defs/protocol_version"},
        "methods": {
            "type": "array",
            "uniqueItems": True,
            "items": {"enum": list(SPEC.method_names)},
        },
    }
    caps |= {a.name: _attribute_schema(a) for a in SPEC.attributes}
    defs = {
        "id": {"type": ["integer", "string"]},
        "protocol_version": {k: v for k, v in _PV.items() if k != "description"},
        "number": {
            "description": "a float64; null stands for a non-finite value",
            "type": ["number", "null"],
        },
        "vector": {"type": "array", "minItems": 1, "items": {"$ref": "#/$defs/number"}},
        "values": {
            "description": "a vector, or nested lists of them (batched requests)",
            "anyOf": [
                {"$ref": "#/$defs/vector"},
                {"type": "array", "minItems": 1, "items": {"$ref": "#/$defs/values"}},
            ],
        },
        "error_reply": {
            "type": "object",
            "required": ["id", "error"],
            "additionalProperties": False,
            "properties": {
                "id": {"$ref": "#/$defs/id"},
                "error": {"type": "string", "minLength": 1},
            },
        },
        "result_reply": {
            "type": "object",
            "required": ["id", "result"],
            "additionalProperties": False,
            "properties": {"id": {"$ref": "#/$defs/id"}, "result": True},
        },
        "reply": {"oneOf": [{"$ref": "#/$defs/result_reply"}, {"$ref": "#/$defs/error_reply"}]},
        "result_pair": {
            "description": "two parts, each a vector (batched: leading axes first)",
            "type": "array",
            "minItems": 2,
            "maxItems": 2,
            "items": {"$ref": "#/$defs/values"},
        },
        "result_capabilities": {
            "description": "The program's declared domain and attributes (the protocol spec's ATTRIBUTES): the certification draws only inside the domain and checks that requests outside it are refused with a 'ValueError: ...' error. Absent keys mean: every algebra, Theta, Upsilon and gravity supported, not batched, no bound on |t|.",
            "type": "object",
            "required": ["protocol_version", "methods"],
            "properties": caps,
        },
    }
    for m in methods:
        ref = "#/$defs/values" if m.result == "tensor" else "#/$defs/result_pair"
        defs[f"result_{m.name}"] = {"description": f"{m.symbol}: {m.doc}", "$ref": ref}
    for name in METHODS:
        defs[f"reply_{name}"] = {
            "oneOf": [
                {
                    "allOf": [
                        {"$ref": "#/$defs/result_reply"},
                        {"properties": {"result": {"$ref": f"#/$defs/result_{name}"}}},
                    ]
                },
                {"$ref": "#/$defs/error_reply"},
            ]
        }
    return {
        **head,
        "title": f"tstarg JSON-lines protocol {SCHEMA_VERSION}: a reply (one JSON object per line on the program's stdout)",
        "description": "Exactly one reply per request, with the request's id, carrying either 'result' or 'error'. Error messages: 'unknown method NAME' (the method is not provided: its checks are skipped); 'ValueError: ...' (a refusal the protocol allows: a degenerate point Delta = 0, or a point outside the declared domain); anything else is a program failure. Non-finite numbers cannot be written in JSON: write null for a non-finite entry (read as NaN).",
        "x-tstarg-protocol-version": SCHEMA_VERSION,
        "$ref": "#/$defs/reply",
        "$defs": defs,
    }


def write_schemas(folder: Path = SCHEMA_DIR) -> list[Path]:
    """Write the generated schemas (``request``, ``reply``) into ``folder``."""
    out = []
    for kind in ("request", "reply"):
        path = Path(folder) / f"{kind}.schema.json"
        path.write_text(json.dumps(build_schema(kind), indent=2) + "\n")
        out.append(path)
    return out


@functools.cache
def _validator(kind: str, method: str | None) -> Draft202012Validator:
    schema = load_schema(kind)
    if method is not None:
        schema = {
            "$schema": schema["$schema"],
            "$defs": schema["$defs"],
            "$ref": f"#/$defs/reply_{method}",
        }
    return Draft202012Validator(schema)


def _where(error) -> str:
    path = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path)
    return path.lstrip(".") or "(the message)"


def _check(kind: str, method: str | None, obj: Any) -> None:
    _check_finite(obj, kind)
    err = best_match(_validator(kind, method).iter_errors(obj))
    if err is not None:
        what = f"{kind}" + (f" to {method}" if method else "")
        raise ProtocolError(
            f"{what} violates the JSON-lines protocol {SCHEMA_VERSION}: at {_where(err)}: "
            f"{err.message[:300]}"
        )


def _check_finite(obj: Any, kind: str) -> None:
    """JSON has no NaN or Infinity (Python's json module writes them anyway): reject them by name."""
    stack = [obj]
    while stack:
        v = stack.pop()
        if isinstance(v, float) and not math.isfinite(v):
            raise ProtocolError(
                f"{kind} contains {v!r}, which is not JSON: write null for a non-finite value"
            )
        if isinstance(v, dict):
            stack.extend(v.values())
        elif isinstance(v, list):
            stack.extend(v)


def validate_request(obj: Any) -> None:
    """Raise :class:`ProtocolError` unless ``obj`` (a parsed JSON object) is a valid request."""
    _check("request", None, obj)


def validate_reply(obj: Any, method: str | None = None) -> None:
    """Raise :class:`ProtocolError` unless ``obj`` is a valid reply; with ``method`` (the request's
    method) the result is checked against that method's result shape too."""
    if method is not None and method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    _check("reply", method, obj)


# ------------------------------------------------------------------ a checker for programs
_EPS = [
    [[0, 0, 0], [0, 0, 1], [0, -1, 0]],
    [[0, 0, -1], [0, 0, 0], [1, 0, 0]],
    [[0, 1, 0], [-1, 0, 0], [0, 0, 0]],
]
SAMPLE_VALUES = {
    "f": _EPS,
    "theta": [[0.0] * 3 for _ in range(3)],
    "upsilon": [[0.0] * 3 for _ in range(3)],
    "inertia": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    "potential": None,
    "x": [0.1, 0.2, 0.3],
    "pi": [1.0, 0.5, -0.2],
    "x0": [0.1, 0.2, 0.3],
    "pi0": [1.0, 0.5, -0.2],
    "t": 0.1,
}
"""One small su(2) value per protocol argument name (a new method's arguments need one here:
``tests/test_schema.py`` checks that every argument of the spec has a sample)."""


def sample_args(method: str) -> dict:
    """The arguments of a small su(2) request to ``method`` (``{}`` for capabilities)."""
    if method == "capabilities":
        return {}
    return {k: SAMPLE_VALUES[k] for k in SPEC.by_name[method].arg_names}


def _sample_requests() -> list[dict]:
    return [{"id": k + 1, "method": m, "args": sample_args(m)} for k, m in enumerate(METHODS)]


def check_program(command: str, *, timeout: float = 30.0) -> list[str]:
    """Send the sample requests to ``command`` and return the protocol violations found (empty: valid)."""
    requests = _sample_requests()
    for req in requests:
        validate_request(req)
    text = "".join(json.dumps(r) + "\n" for r in requests)
    try:
        done = subprocess.run(
            shlex.split(command),
            check=False,
            input=text,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        return [
            f"no complete answer within {timeout} s (each request needs exactly one reply line)"
        ]
    problems, seen = [], {}
    for k, line in enumerate(done.stdout.splitlines(), 1):
        try:
            msg = json.loads(line)
        except json.JSONDecodeError as exc:
            problems.append(f"stdout line {k} is not JSON ({exc}): {line[:120]!r}")
            continue
        rid = msg.get("id") if isinstance(msg, dict) else None
        method = next((r["method"] for r in requests if r["id"] == rid), None)
        if method is None:
            problems.append(f"stdout line {k}: reply id {rid!r} matches no request")
            continue
        seen[rid] = msg
        try:
            validate_reply(msg, method)
        except ProtocolError as exc:
            problems.append(f"stdout line {k}: {exc}")
    problems += [
        f"no reply to request {r['id']} ({r['method']})" for r in requests if r["id"] not in seen
    ]
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m tstarg.reports.jsonl_schema",
        description="Validate a JSON-lines program's replies against the protocol schema.",
    )
    ap.add_argument("--cmd", help='the program, e.g. --cmd "node examples/js/client.mjs"')
    ap.add_argument(
        "--write-schemas",
        action="store_true",
        help="regenerate reports/schema/*.schema.json from the protocol spec (maintainers)",
    )
    ap.add_argument("--timeout", type=float, default=30.0)
    a = ap.parse_args(argv)
    if a.write_schemas:
        for path in write_schemas():
            print(f"wrote {path}")
        return 0
    if not a.cmd:
        ap.error("--cmd is required")
    problems = check_program(a.cmd, timeout=a.timeout)
    for p in problems:
        print(p)
    print(
        f"JSON-lines protocol {SCHEMA_VERSION}: {'valid' if not problems else f'{len(problems)} violation(s)'}"
    )
    return 1 if problems else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
