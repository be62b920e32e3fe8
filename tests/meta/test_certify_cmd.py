"""``tstarg certify --cmd``: a program speaking JSON lines is certified like a Python object; a
program that hangs on one request and crashes on another is reported, and the harness finishes."""

from __future__ import annotations

import sys
from pathlib import Path

from tstarg.reports.certification import certify
from tstarg.reports.jsonl import CommandImplementation, ProgramFailure

PROGRAM = f"{sys.executable} {Path(__file__).with_name('jsonl_program.py')}"


def test_cmd_implementation_certifies():
    impl = CommandImplementation(PROGRAM, timeout=20)
    try:
        cert = certify(impl, max_examples=6, seed=0, target="--cmd jsonl_program.py")
    finally:
        impl.close()
    assert cert.passed, cert.summary()
    assert "flow.reference" in cert.skipped and not impl.incidents


def test_hang_and_crash_are_reported_and_harness_finishes(tmp_path):
    # requests 1-3 are the capability probe; request 5 hangs, request 8 crashes (counted across restarts)
    impl = CommandImplementation(
        f"{PROGRAM} --hang-on 5 --crash-on 8 --state {tmp_path / 'count'}", timeout=2
    )
    try:
        cert = certify(
            impl,
            max_examples=6,
            seed=0,
            target="--cmd flaky",
            checks=["poisson_tensor.reference"],
            shrink=False,
        )  # only the verdict and the incidents are checked
    finally:
        impl.close()
    kinds = [i["kind"] for i in cert.incidents]
    assert kinds.count("hang") == 1 and kinds.count("crash") == 1, cert.incidents
    assert not cert.passed and "hang" in cert.summary() and "crash" in cert.to_markdown()


def test_cli_reports_incidents(tmp_path, capsys):
    from tstarg.reports.cli import main

    rc = main(
        [
            "certify",
            "--cmd",
            f"{PROGRAM} --hang-on 6 --crash-on 9 --state {tmp_path / 'count'}",
            "--timeout",
            "2",
            "--max-examples",
            "4",
            "--out",
            str(tmp_path),
            "--workers",
            "1",
        ]
    )  # one program: the count is global
    out = capsys.readouterr().out
    assert rc == 1 and "hang" in out and "crash" in out
    assert (tmp_path / "certificate.json").exists() and (tmp_path / "certificate.md").exists()


def test_unknown_method_is_skipped():
    impl = CommandImplementation(f"{PROGRAM} --only poisson_tensor", timeout=20)
    try:
        assert not hasattr(impl, "hamiltonian_vector_field")
        cert = certify(
            impl,
            max_examples=3,
            seed=0,
            checks=["hamiltonian_vector_field.reference", "poisson_tensor.antisymmetry"],
        )
    finally:
        impl.close()
    assert "hamiltonian_vector_field.reference" in cert.skipped and cert.passed


def test_program_failure_is_not_a_value_error():
    assert not issubclass(ProgramFailure, ValueError)
