"""``tstarg certify`` as a process: no false "certified", no hang, no crash, whatever the target.

Issue 15 (findings 2, 5, 9) and issue 19 (deliverables 2, 3): each reproducer is a test. The
targets are in ``tests/meta/targets.py`` (Python objects) and ``tests/meta/bad_program.py``
(JSON-lines programs, one misbehaviour per mode).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

from tstarg.reports import cli

HERE = Path(__file__).parent / "meta"
BAD = f"{sys.executable} {HERE / 'bad_program.py'}"
FAST = [
    "--profile",
    "dev",
    "--max-examples",
    "2",
    "--workers",
    "1",
    "--check-seconds",
    "30",
    "--shrink-seconds",
    "3",
]


def certify(tmp_path, *argv):
    rc = cli.main(["certify", *argv, "--out", str(tmp_path), *FAST])
    cert = (
        json.loads((tmp_path / "certificate.json").read_text())
        if (tmp_path / "certificate.json").exists()
        else None
    )
    return rc, cert


def by_name(cert, name):
    (c,) = [c for c in cert["checks"] if c["name"] == name]
    return c


# ------------------------------------------------------------------ bad arguments: exit 2, a clear message
@pytest.mark.parametrize("timeout", ["0", "-1", "nan", "inf", "1e9"])
def test_timeout_must_be_positive_and_bounded(tmp_path, capsys, timeout):
    rc, cert = certify(tmp_path, "tstarg.refimpl.fast:implementation", "--timeout", timeout)
    err = capsys.readouterr().err
    assert rc == 2 and cert is None and "--timeout" in err and "(0, 3600]" in err


def test_nonexistent_program_is_a_clear_error(tmp_path, capsys):
    rc, cert = certify(tmp_path, "--cmd", "/nonexistent/program --flag")
    err = capsys.readouterr().err
    assert rc == 2 and cert is None
    assert "/nonexistent/program" in err and "Traceback" not in err


def test_not_an_implementation_is_refused(tmp_path, capsys):
    """The object 42 provides no protocol method: refused, never PASS with every check skipped."""
    rc, cert = certify(tmp_path, "tests.meta.targets:not_an_implementation")
    err = capsys.readouterr().err
    assert rc == 2 and cert is None and "none of the protocol's methods" in err


# ------------------------------------------------------------------ module targets that misbehave
def test_sys_exit_in_a_method_fails_with_a_certificate(tmp_path):
    rc, cert = certify(
        tmp_path, "tests.meta.targets:exits", "--check", "poisson_tensor.antisymmetry"
    )
    assert rc == 1 and cert is not None and not cert["passed"]
    assert (
        cert["implementation"] == "tests.meta.targets:exits"
    )  # a nameless target: named by its spec
    c = by_name(cert, "poisson_tensor.antisymmetry")
    assert not c["passed"] and "sys.exit(0)" in c["detail"]


@pytest.mark.parametrize("target", ["garbage", "nothing"])
def test_garbage_result_never_passes_the_degenerate_check(tmp_path, target):
    """Returning "abc" or None is not "refused the degenerate point"."""
    rc, cert = certify(
        tmp_path, f"tests.meta.targets:{target}", "--check", "poisson_tensor.degenerate"
    )
    assert rc == 1
    c = by_name(cert, "poisson_tensor.degenerate")
    assert not c["passed"] and "real numbers" in c["detail"] + c["falsifying_example"]


def test_mutating_inputs_fails_with_the_reason(tmp_path):
    rc, cert = certify(
        tmp_path, "tests.meta.targets:mutates", "--check", "poisson_tensor.antisymmetry"
    )
    assert (
        rc == 1
        and "mutated its input 'x'" in by_name(cert, "poisson_tensor.antisymmetry")["detail"]
    )


def test_module_target_call_timeout(tmp_path):
    """A method that never returns: each call is cut at --timeout; after three the checks stop calling."""
    rc, cert = certify(
        tmp_path,
        "tests.meta.targets:sleeps",
        "--timeout",
        "0.5",
        "--check",
        "poisson_tensor.degenerate",
    )
    assert rc == 1 and not cert["passed"]
    hangs = [i for i in cert["incidents"] if i["kind"] == "hang"]
    assert len(hangs) == 3, cert["incidents"]
    assert all(not c["passed"] for c in cert["checks"])


def test_a_module_is_a_valid_target(tmp_path):
    rc, cert = certify(tmp_path, "tests.meta.module_impl")
    assert rc == 0 and cert["passed"] and cert["implementation"] == "module target"
    assert sum(c["examples"] for c in cert["checks"]) > 0


# ------------------------------------------------------------------ programs that misbehave
@pytest.mark.parametrize(
    "mode,kind",
    [
        ("garbage", "garbage"),
        ("exit", "crash"),
        ("silent", "hang"),
        ("flood", "garbage"),  # replies with an id no request has: refused at once
        ("abc", "malformed"),
        ("noresult", "malformed"),
    ],
)
def test_broken_program_fails_fast_with_its_incidents(tmp_path, mode, kind):
    """Each ends as FAIL with incidents of its kind; three failed requests in a row and the program
    is declared broken (no one-timeout-per-example run of many minutes)."""
    rc, cert = certify(
        tmp_path,
        "--cmd",
        f"{BAD} {mode}",
        "--timeout",
        "1",
        "--startup-timeout",
        "1",
        "--check",
        "poisson_tensor.degenerate",
    )
    assert rc == 1 and cert is not None and not cert["passed"]
    kinds = {i["kind"] for i in cert["incidents"]}
    assert kind in kinds, cert["incidents"]
    assert len(cert["incidents"]) == 3  # max_failures, then the program is broken: no more requests
    assert not by_name(cert, "poisson_tensor.degenerate")["passed"]


@pytest.mark.slow
def test_nan_answers_fail(tmp_path):
    rc, cert = certify(
        tmp_path, "--cmd", f"{BAD} nan", "--timeout", "5", "--check", "poisson_tensor.reference"
    )
    assert rc == 1
    c = by_name(cert, "poisson_tensor.reference[generic]")
    assert not c["passed"] and c["worst_ratio"] == "inf"


def test_forking_program_leaves_no_children(tmp_path):
    pids = tmp_path / "pids"
    rc, cert = certify(
        tmp_path,
        "--cmd",
        f"{BAD} fork {pids}",
        "--timeout",
        "20",
        "--check",
        "poisson_tensor.antisymmetry",
    )
    assert rc == 0, cert
    kids = [int(p) for p in pids.read_text().split()]
    assert kids
    for pid in kids:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            continue
        state = (
            Path(f"/proc/{pid}/stat").read_text().split()[2]
            if Path(f"/proc/{pid}/stat").exists()
            else "X"
        )
        assert state == "Z" or state == "X", f"child {pid} still running (state {state})"


def test_program_stderr_is_kept_and_quoted_per_incident(tmp_path):
    rc, cert = certify(
        tmp_path, "--cmd", f"{BAD} stderr", "--timeout", "20", "--check", "poisson_tensor.reference"
    )
    assert rc == 1
    log = (tmp_path / "program-stderr.log").read_text()
    assert "stderr line for request 1" in log and "fatal: planted crash" in log
    crashes = [
        i for i in cert["incidents"] if i["kind"] == "crash"
    ]  # every 6th request of each program run
    assert crashes and all(i["stderr_tail"][-1] == "fatal: planted crash" for i in crashes)
    md = (tmp_path / "certificate.md").read_text()
    assert "program-stderr.log" in md and "fatal: planted crash" in md


def test_implementation_using_the_whole_example_budget_fails(tmp_path):
    """A per-example budget shorter than --timeout: the time went to the implementation, so it is
    its failure (not an example 'drawn again' as when the reference computation is too costly)."""
    rc, cert = certify(
        tmp_path,
        "tests.meta.targets:sleeps",
        "--timeout",
        "100",
        "--example-seconds",
        "0.5",
        "--check",
        "poisson_tensor.degenerate",
    )
    c = by_name(cert, "poisson_tensor.degenerate")
    assert rc == 1 and not c["passed"] and "still running when the example's budget" in c["detail"]


# ------------------------------------------------------------------ one run-and-merge
def test_one_run_and_merge_for_in_process_guarded_and_parallel_runs():
    """certify_target is the one run-and-merge: unguarded over two workers it gives the serial
    certify's checks (names, example counts, verdicts); guarded in-process on an object it gives
    them too."""
    from tstarg.refimpl.fast import implementation as fast
    from tstarg.reports.certification import certify as serial
    from tstarg.reports.certification.run import certify_target

    kw = {"max_examples": 2, "seed": 0, "checks": ["poisson_tensor.antisymmetry", "flow.order"]}
    want = serial(fast, **kw)
    par = certify_target("tstarg.refimpl.fast:implementation", workers=2, guard=False, **kw)
    obj = certify_target(fast, workers=1, **kw)

    def key(c):
        return [(r.name, r.examples, r.passed) for r in c.checks], sorted(c.skipped)

    assert key(par) == key(want) == key(obj)
