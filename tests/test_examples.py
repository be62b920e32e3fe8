"""The example clients of the JSON-lines protocol (examples/): each speaks the schema, is certified by
``tstarg certify --cmd`` against the mpmath reference, and a copy with one planted mistake is rejected.
Skipped, with the reason, when the language's runtime (gcc, node) is missing."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tstarg.reports.certification import certify
from tstarg.reports.jsonl import CommandImplementation
from tstarg.reports.jsonl_schema import check_program

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
POISSON = ["poisson_tensor.reference", "poisson_tensor.antisymmetry", "poisson_tensor.degenerate"]


def _certify_cli(cmd: str, out: Path, seed: int = 0) -> tuple[int, dict, str]:
    """``python -m tstarg.reports.cli certify --cmd CMD`` with a small budget (the test stays well under 30 s)."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "tstarg.reports.cli",
            "certify",
            "--cmd",
            cmd,
            "--max-examples",
            "4",
            "--seed",
            str(seed),
            "--workers",
            "1",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=240,
        env=env,
        check=False,
    )
    cert = (
        json.loads((out / "certificate.json").read_text())
        if (out / "certificate.json").exists()
        else {}
    )
    return done.returncode, cert, done.stdout + done.stderr


def _assert_certified(cmd: str, tmp_path: Path) -> None:
    assert check_program(cmd) == [], "the replies must validate against reports/schema/"
    rc, cert, log = _certify_cli(cmd, tmp_path / "cert")
    assert rc == 0 and cert["passed"], log
    ran = {c["name"].split("[")[0] for c in cert["checks"]}
    assert set(POISSON) <= ran, ran  # every Poisson-tensor check ran (none skipped) ...
    assert (
        sum(c["examples"] for c in cert["checks"] if c["name"].startswith("poisson_tensor.")) >= 20
    )
    # ... and the methods the client does not provide are skipped, saying so
    for cid in ("hamiltonian_vector_field.reference", "flow.reference"):
        assert cid in cert["skipped"] and cid.split(".")[0] in cert["skipped"][cid]


def _assert_rejected(cmd: str) -> None:
    impl = CommandImplementation(cmd, timeout=30)
    try:
        # the verdict is all that matters here: no shrinking, the reference check only
        cert = certify(
            impl,
            max_examples=4,
            seed=0,
            checks=["poisson_tensor.reference"],
            shrink=False,
            target=cmd,
        )
    finally:
        impl.close()
    assert not cert.passed, cert.summary()


def _mutate(src: Path, dst: Path, old: str, new: str) -> Path:
    text = src.read_text()
    assert text.count(old) == 1, f"mutation anchor {old!r} not found once in {src}"
    dst.write_text(text.replace(old, new))
    return dst


def _gcc(src: Path, exe: Path) -> None:
    subprocess.run(
        ["gcc", "-O2", "-std=c99", "-Wall", "-Werror", "-o", str(exe), str(src), "-lm"],
        check=True,
        capture_output=True,
        timeout=120,
    )


@pytest.mark.skipif(
    shutil.which("gcc") is None, reason="gcc not found: the C example client cannot be built"
)
def test_c_client_is_certified_and_a_broken_copy_rejected(tmp_path):
    src = EXAMPLES / "c" / "tstarg_client.c"
    _gcc(src, tmp_path / "client")
    _assert_certified(str(tmp_path / "client"), tmp_path)
    # planted mistake: the frame L(g, e) = phi1(-ad_x)^-1 built from +ad_x (the frame of the wrong side)
    broken = _mutate(
        src,
        tmp_path / "broken.c",
        "AT(big, N, i, j) = -AT(ad, n, i, j);",
        "AT(big, N, i, j) = AT(ad, n, i, j);",
    )
    _gcc(broken, tmp_path / "broken")
    _assert_rejected(str(tmp_path / "broken"))


@pytest.mark.skipif(
    shutil.which("node") is None, reason="node not found: the JavaScript example client cannot run"
)
def test_js_client_is_certified_and_a_broken_copy_rejected(tmp_path):
    src = EXAMPLES / "js" / "tstarg_client.mjs"
    node = shutil.which("node")
    _assert_certified(f"{node} {src}", tmp_path)
    # planted mistake: Psi^-1 taken as Phi^-1 (not transposed) in the {x, pi} block
    broken = _mutate(
        src,
        tmp_path / "broken.mjs",
        "const xp = matmul(L, PsiInv);",
        "const xp = matmul(L, PhiInv);",
    )
    _assert_rejected(f"{node} {broken}")


def test_ci_workflow_example_certifies_on_push():
    yaml = pytest.importorskip("yaml", reason="PyYAML not installed (it comes with the docs extra)")
    wf = yaml.safe_load((EXAMPLES / "ci" / "github-workflow.yml").read_text())
    assert "push" in wf[True] or "push" in wf.get("on", {})  # YAML 1.1 reads the key `on` as True
    steps = [s.get("run", "") for job in wf["jobs"].values() for s in job["steps"]]
    certify_steps = [s for s in steps if "tstarg certify" in s]
    assert certify_steps and all("--cmd" in s or ":" in s for s in certify_steps)
    text = (EXAMPLES / "ci" / "github-workflow.yml").read_text()
    assert "junit" in text.lower()


def test_jaxlie_su2_only_implementation_certified_in_its_domain(monkeypatch):
    """examples/jaxlie_su2: an su(2)-only implementation on jaxlie declares its domain (su(2),
    Upsilon = 0, no potential, |t| <= 100); it is certified there, the certificate states the domain,
    and the copy with the right-invariant frame in place of the left-invariant one is rejected."""
    pytest.importorskip("jaxlie", reason="jaxlie not installed (pip install -e '.[jaxlie]')")
    from tstarg.reports import certification

    if not hasattr(certification, "declared_domain"):
        pytest.skip("the certification does not read declared domains yet (issue 18, deliver 1)")
    monkeypatch.syspath_prepend(str(EXAMPLES / "jaxlie_su2"))
    import su2_jaxlie

    cert = certify(
        su2_jaxlie.implementation, max_examples=4, seed=0, target="su2_jaxlie:implementation"
    )
    assert cert.passed, cert.summary()
    assert "su(2)" in cert.domain and "Upsilon = 0" in cert.domain and "100" in cert.domain
    ran = {c.name.split("[")[0] for c in cert.checks}
    assert {
        "poisson_tensor.reference",
        "hamiltonian_vector_field.reference",
        "flow.reference",
        "domain.refusal",
    } <= ran
    bad = certify(
        su2_jaxlie.broken_implementation,
        max_examples=4,
        seed=0,
        shrink=False,
        stop_on_failure=True,
        checks=["poisson_tensor.reference"],
        target="su2_jaxlie:broken_implementation",
    )
    assert not bad.passed, bad.summary()
