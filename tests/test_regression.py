"""Regression reports: ``tstarg verify`` against a baseline and ``tstarg report --compare`` flag
accuracy (digits lost) and speed (speed-up ratios) regressions; a planted degraded run fails."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from tstarg.reports import regression
from tstarg.reports.cli import main

PROVIDERS = [
    "--provider",
    "tstarg.properties.core_checks:core_checks",
    "--provider",
    "tstarg.reports.speed_checks:speed_checks",
]


def _rep(checks, profile="ci", n=20, seed=0):
    return {"profile": profile, "max_examples": n, "seed": seed, "checks": checks}


def _row(name, digits=None, ratio=0.0, passed=True, speedup=None):
    return {
        "name": name,
        "min_digits": digits,
        "worst_ratio": ratio,
        "passed": passed,
        "extra": {} if speedup is None else {"speedup": speedup},
    }


def test_digits_lost_by_hand():
    """Digits lost = max(drop of min digits, log10 growth of the worst ratio); worked by hand."""
    base = _rep(
        [
            _row("a", 15.0, 1e-3),
            _row("b", 12.0, 1e-2),
            _row("c", math.inf, 0.0),
            _row("d", None, 1e-4),
        ]
    )
    new = _rep(
        [_row("a", 14.5, 1e-2), _row("b", 9.5, 1e-2), _row("c", 30.0, 0.0), _row("d", None, 1e-1)]
    )
    cmp = regression.compare(base, new, digits_slack=2.0)
    lost = {r["name"]: r["digits_lost"] for r in cmp["rows"]}
    assert lost["a"] == pytest.approx(1.0)  # ratio grew 10x: 1 digit; min digits dropped 0.5
    assert lost["b"] == pytest.approx(2.5)  # min digits dropped 2.5, ratio unchanged
    assert lost["c"] == math.inf  # was exact, is not any more
    assert lost["d"] == pytest.approx(3.0)  # only a ratio: 1e-4 -> 1e-1
    assert cmp["accuracy_regressions"] == ["b", "c", "d"] and cmp["regressed"]


def test_speed_regression_by_ratio_not_seconds():
    """A speed-up fallen by more than the factor regresses; one fallen less, or risen, does not."""
    base = _rep([_row("s1", speedup=20.0), _row("s2", speedup=20.0), _row("s3", speedup=2.0)])
    new = _rep([_row("s1", speedup=9.0), _row("s2", speedup=11.0), _row("s3", speedup=5.0)])
    cmp = regression.compare(base, new, speed_factor=2.0)
    assert cmp["speed_regressions"] == ["s1"] and not cmp["accuracy_regressions"]
    assert {r["name"]: r["speed_factor"] for r in cmp["rows"]}["s1"] == pytest.approx(20 / 9)


def test_verdicts_missing_new_and_sampling():
    """PASS -> FAIL always regresses; different samples make digit changes informational;
    missing and new checks are listed, not failed."""
    base = _rep([_row("a", 15.0), _row("gone", 15.0), _row("v", 15.0)])
    new = _rep(
        [_row("a", 5.0), _row("fresh", 15.0), _row("v", 15.0, passed=False)],
        profile="thorough",
        n=60,
    )
    cmp = regression.compare(base, new)
    st = {r["name"]: r["status"] for r in cmp["rows"]}
    assert st["a"] == ["accuracy change (different samples)"]
    assert st["gone"] == ["missing in new run"] and st["fresh"] == ["new check"]
    assert "verdict regression (PASS -> FAIL)" in st["v"]
    assert cmp["accuracy_regressions"] == ["v"]
    acc, spd = regression.regression_checks(cmp)
    assert not acc.passed and spd.passed


@pytest.mark.parametrize(
    "kw", [{"digits_slack": -1.0}, {"speed_factor": 0.5}, {"digits_slack": math.nan}]
)
def test_bad_thresholds(kw):
    with pytest.raises(ValueError, match="must be a finite number"):
        regression.compare(_rep([]), _rep([]), **kw)


def test_load_report_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="no report"):
        regression.load_report(tmp_path)
    (tmp_path / "report.json").write_text('{"checks": 3}')
    with pytest.raises(ValueError, match="not a tstarg verify report"):
        regression.load_report(tmp_path)


@pytest.fixture(scope="module")
def base_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("base")
    assert (
        main(
            [
                "verify",
                *PROVIDERS,
                "--max-examples",
                "3",
                "--out",
                str(out),
                "--no-baseline",
                "--quiet",
            ]
        )
        == 0
    )
    return out


def test_planted_degraded_run_fails(base_run, tmp_path, monkeypatch):
    """A fast implementation made 10x slower and ~100x less accurate -- still inside its own error
    bound, so every accuracy check alone passes -- is caught by the comparison with the baseline run."""
    from tstarg.refimpl.fast import Fast

    original = Fast.poisson_batch

    def degraded(self, *args, **kwargs):
        for _ in range(9):
            original(self, *args, **kwargs)
        res = original(self, *args, **kwargs)
        bound = np.asarray(res.error_bound, dtype=float)
        P = np.array(res.P, copy=True)
        # an error of 0.9 x the bound on every entry: still passes the per-check tolerance
        P += (
            0.9
            * np.where(np.isfinite(bound), bound, 0.0)[..., None, None]
            * np.sign(np.arange(P.shape[-1]) - 2.5)
        )
        return dataclasses.replace(res, P=P)

    monkeypatch.setattr(Fast, "poisson_batch", degraded)
    out = tmp_path / "degraded"
    rc = main(
        [
            "verify",
            *PROVIDERS,
            "--max-examples",
            "3",
            "--out",
            str(out),
            "--baseline",
            str(base_run),
            "--digits-slack",
            "1",
            "--quiet",
        ]
    )
    rep = json.loads((out / "report.json").read_text())
    rows = {c["name"]: c for c in rep["checks"]}
    assert rc == 1
    # the accuracy checks themselves pass (every error is inside its bound): only the comparison
    # sees the degradation (speed rows may fail on their own, 10x slower than per-point numpy)
    assert not [
        (n, c["detail"])
        for n, c in rows.items()
        if not n.startswith(("regression.", "speed.")) and not c["passed"]
    ]
    assert not rows["regression.accuracy"]["passed"] and not rows["regression.speed"]["passed"]
    cmp = rep["comparison"]
    assert "fast_matches_reference[generic]" in cmp["accuracy_regressions"]
    assert set(cmp["speed_regressions"]) >= {"speed.poisson[su2]", "speed.poisson[su3]"}
    assert (
        "speed.flow[heavy_top]" not in cmp["speed_regressions"]
    )  # the flow does not use poisson_batch
    assert (out / "compare.md").exists() and (out / "figures" / "compare.png").stat().st_size > 1000
    assert "Against the baseline" in (out / "report.md").read_text()
    # the same verdict from `tstarg report --compare A B`
    assert (
        main(
            [
                "report",
                "--compare",
                str(base_run),
                str(out),
                "--out",
                str(tmp_path / "cmp"),
                "--digits-slack",
                "1",
            ]
        )
        == 1
    )
    assert "REGRESSED" in (tmp_path / "cmp" / "compare.md").read_text()


def test_clean_rerun_has_no_accuracy_regression(tmp_path):
    """The same code, seed and profile reproduce the baseline's digits exactly (no false alarm).
    Speed is not judged here: this test must not depend on the machine's load. The baseline is
    run here, just before the rerun: the module's shared base run is made once per process, and
    in a process that ran other test files first it was once seen to differ by 1.6 digits in
    fast_matches_reference[near_degenerate] (not root-caused; see the closing note of this stop)."""
    base_run = tmp_path / "base"
    assert (
        main(
            [
                "verify",
                *PROVIDERS,
                "--max-examples",
                "3",
                "--out",
                str(base_run),
                "--no-baseline",
                "--quiet",
            ]
        )
        == 0
    )
    out = tmp_path / "again"
    rc = main(
        [
            "verify",
            *PROVIDERS,
            "--max-examples",
            "3",
            "--out",
            str(out),
            "--baseline",
            str(base_run),
            "--speed-factor",
            "1e9",
            "--quiet",
        ]
    )
    rep = json.loads((out / "report.json").read_text())
    assert rc == 0 and not rep["comparison"]["regressed"]
    lost = [r["digits_lost"] for r in rep["comparison"]["rows"] if r["digits_lost"] is not None]
    assert lost and max(lost) == pytest.approx(0.0, abs=1e-9)
    assert main(["report", str(out)]) == 0


def test_committed_baseline_is_a_full_ci_run():
    """The committed baseline is a passing ``--profile ci --seed 0`` run of every default provider."""
    from tstarg.reports._verify import PROFILES
    from tstarg.reports._verify import PROVIDERS as DEFAULT

    base = regression.load_report(regression.BASELINE)
    assert (base["profile"], base["max_examples"], base["seed"]) == ("ci", PROFILES["ci"], 0)
    assert base["passed"] and all(c["passed"] for c in base["checks"])
    assert set(base["providers"]) == set(DEFAULT)
    assert all("speedup" in c["extra"] for c in base["checks"] if c["name"].startswith("speed."))
