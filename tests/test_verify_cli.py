"""``tstarg verify`` runs every provider's checks, writes report.json and report.md, prints the
summary table, skips providers whose module does not exist and exits non-zero on any failure."""

from __future__ import annotations

import json

import pytest

from tstarg.properties.runner import CheckResult, run_property
from tstarg.reports import _verify as verify
from tstarg.reports import cli


def passing_provider(max_examples, seed):
    """A provider whose one check passes (ratio 0.5 on every example)."""
    from hypothesis import strategies as st

    return [
        run_property(
            "always_half",
            "test",
            lambda x: (0.5, 10.0),
            st.integers(0, 3),
            max_examples=max_examples,
            seed=seed,
        )
    ]


def failing_provider(max_examples, seed):
    """A provider whose check fails once the drawn integer exceeds 2 (ratio x)."""
    from hypothesis import strategies as st

    return [
        run_property(
            "fails_above_two",
            "test",
            lambda x: (float(x), None),
            st.integers(0, 100),
            max_examples=max_examples,
            seed=seed,
        )
    ]


def crashing_provider(max_examples, seed):
    raise RuntimeError("provider bug")


def _run(tmp_path, *providers, extra=()):
    argv = [
        "verify",
        "--max-examples",
        "5",
        "--seed",
        "3",
        "--out",
        str(tmp_path),
        "--quiet",
        "--no-baseline",
    ]
    for p in providers:
        argv += ["--provider", p]
    return cli.main(argv + list(extra))


def test_passing_run_writes_reports(tmp_path, capsys):
    """All checks pass: exit 0, report.json lists every check with its ratio; report.md has the table."""
    rc = _run(tmp_path, f"{__name__}:passing_provider")
    assert rc == 0
    rep = json.loads((tmp_path / "report.json").read_text())
    assert rep["passed"] and rep["max_examples"] == 5 and rep["seed"] == 3
    (check,) = rep["checks"]
    assert check["name"] == "always_half" and check["worst_ratio"] == 0.5 and check["examples"] >= 1
    md = (tmp_path / "report.md").read_text()
    assert "| always_half |" in md and "PASS" in md
    out = capsys.readouterr().out
    assert "worst ratio" in out and "always_half" in out


def test_failing_check_exits_nonzero(tmp_path, capsys):
    """A failing check (shrunk by Hypothesis to the smallest failing integer, 2 < x) makes verify exit 1."""
    rc = _run(
        tmp_path,
        f"{__name__}:passing_provider",
        f"{__name__}:failing_provider",
        extra=["--max-examples", "50"],
    )
    assert rc == 1
    rep = json.loads((tmp_path / "report.json").read_text())
    bad = [c for c in rep["checks"] if not c["passed"]]
    assert [c["name"] for c in bad] == ["fails_above_two"]
    assert "ratio 2 > 1" in bad[0]["detail"] or "> 1" in bad[0]["detail"]
    assert "FAIL" in (tmp_path / "report.md").read_text()


def test_missing_providers(tmp_path):
    """A missing default provider (issue not merged) is skipped; a missing requested one fails."""
    results, status = verify.run_providers(
        ["no_such_module:checks"], 2, 0, optional=("no_such_module:checks",)
    )
    assert results == [] and status["no_such_module:checks"].startswith("skipped")
    assert _run(tmp_path, "no_such_module:checks") == 1
    rep = json.loads((tmp_path / "report.json").read_text())
    assert "not found" in rep["checks"][0]["detail"]


def test_crashing_provider_is_a_failed_check(tmp_path):
    """A provider that raises becomes a failed check carrying its traceback, not a crash of verify."""
    rc = _run(tmp_path, f"{__name__}:crashing_provider")
    assert rc == 1
    rep = json.loads((tmp_path / "report.json").read_text())
    assert rep["checks"][0]["name"] == f"provider[{__name__}:crashing_provider]"
    assert "provider bug" in rep["checks"][0]["detail"]


@pytest.mark.parametrize("spec", ["no_colon", "a:b:c"])
def test_bad_provider_spec(tmp_path, spec):
    """A provider spec that is not module:function is a clear ValueError."""
    with pytest.raises(ValueError, match="module:function"):
        _run(tmp_path, spec)


def test_progress_lines(capsys):
    """The progress display (non-terminal output) prints which check starts, then one line when it is done."""
    prog = verify.Progress()
    prog("start", "c1", 0, 3)
    prog("example", "c1", 1, 3)
    started = capsys.readouterr().out
    assert started.count("\n") == 1 and "c1" in started and "running" in started
    prog("done", "c1", 3, 3, CheckResult(name="c1", equations="e", examples=3))
    out = capsys.readouterr().out
    assert out.count("\n") == 1 and "c1" in out and "PASS" in out


def test_default_providers_include_the_paper_checks():
    """The default provider list runs the core checks, the paper's identities and (when present) the oracles."""
    assert verify.PROVIDERS[:2] == (
        "tstarg.properties.core_checks:core_checks",
        "tstarg.properties.identity_checks:identity_checks",
    )
    assert "tstarg.oracles.oracle_checks:oracle_checks" in verify.PROVIDERS


def test_paper_checks_all_pass_small_budget():
    """Every paper identity passes and every negative control bites, at a budget of 2 examples."""
    from tstarg.properties.identity_checks import identity_checks

    results = identity_checks(2, seed=0)
    failed = [(r.name, r.detail) for r in results if not r.passed]
    assert not failed, failed
    names = {r.name for r in results}
    for prop in ("closedness", "antisymmetry", "jacobi", "darboux", "whitehead"):
        assert any(n.startswith(prop) for n in names), prop
        assert any(n.startswith(f"negative[{prop}") for n in names), (
            f"no negative control for {prop}"
        )
