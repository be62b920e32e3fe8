"""tstarg stress: a quick run writes its report with zero silent failures; planted broken
implementations are caught (silent failures, bound violations, exit 1); the Brouwer fit
recovers known exponents and the real long integration follows Brouwer's law."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from tstarg.refimpl.fast import implementation as _fast
from tstarg.reports import _stress, cmd_stress
from tstarg.reports.cli import build_parser


def _run(argv):
    args = build_parser().parse_args(["stress", *argv])
    return args._main(args)


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("stress_quick")
    code = _run(["--quick", "--workers", "1", "--out", str(out)])
    return code, out, json.loads((out / "report.json").read_text())


def test_quick_run_writes_report_without_silent_failures(quick_run):
    """--quick through the CLI: report.json, report.md and one PNG per sweep; every point ok/escalated/flagged."""
    code, out, rep = quick_run
    assert (out / "report.md").is_file() and (out / "brouwer.png").is_file()
    names = {s["name"] for s in rep["sweeps"]}
    assert {
        "degenerate-su2",
        "degenerate-bianchi-vi",
        "momenta-su2",
        "basis-su2",
        "upsilon-su2",
        "field-degenerate-su2",
    } <= names
    md = (out / "report.md").read_text()
    for s in rep["sweeps"]:
        assert s["rows"], s["name"]
        assert (out / f"{s['name']}.png").stat().st_size > 1000 and f"({s['name']}.png)" in md
    assert rep["summary"]["judge_problems"] == 0
    rows = [r for s in rep["sweeps"] for r in s["rows"]]
    assert {r["outcome"] for r in rows} <= {"ok", "escalated", "flagged"}
    assert all(r["bound_held_fast"] and r["bound_held_final"] for r in rows)
    # the sweeps reach the hard regimes: points over the tolerance exist and were escalated
    assert sum(r["outcome"] == "escalated" for r in rows) >= 5
    # the C1 = 0 point is flagged, kept in its sweep (never dropped)
    exact = [r for r in rows if r["label"] == "C1 = 0 exactly"]
    assert exact and all(r["outcome"] == "flagged" for r in exact)
    assert code in (0, 1) and (code == 1) == bool(
        rep["summary"]["bound_violations_fast"] or rep["summary"]["bound_violations_final"]
    )


def test_quick_run_has_zero_silent_failures_in_every_sweep(quick_run):
    """Zero silent failures and no bound violation on all quick sweeps, so the run exits 0.

    (Before the fix of refimpl.fast's error model -- rounding in forming S = pi.f - Theta and
    ad_x = x.f, and cond(I) in the field -- the ill-conditioned-basis sweeps had silent failures
    with errors up to 1.3e7 x the bound.)"""
    code, _, rep = quick_run
    assert rep["summary"]["silent_failures"] == 0
    assert rep["summary"]["bound_violations_fast"] == 0 and code == 0


# ---------------------------------------------------------------- planted
@dataclasses.dataclass
class Planted:
    """The fast implementation with its error bound shrunk and/or noise added to P and the field."""

    shrink: float = 1.0
    noise: float = 0.0

    def _perturb(self, a):
        a = np.asarray(a, dtype=float)
        return a * (1 + self.noise * np.cos(np.arange(a.size)).reshape(a.shape))

    def poisson_batch(self, *args, **kw):
        r = _fast.poisson_batch(*args, **kw)
        return dataclasses.replace(r, P=self._perturb(r.P), error_bound=r.error_bound / self.shrink)

    def vector_field_batch(self, *args, **kw):
        r = _fast.vector_field_batch(*args, **kw)
        return dataclasses.replace(
            r,
            xdot=self._perturb(r.xdot),
            pidot=self._perturb(r.pidot),
            error_bound=r.error_bound / self.shrink,
        )


SHRUNK = Planted(shrink=1e6)
NOISY = Planted(noise=1e-7)


@pytest.mark.parametrize(
    ("planted", "what"), [("SHRUNK", "bound_violations_fast"), ("NOISY", "silent_failures")]
)
def test_planted_broken_implementation_is_caught(planted, what, tmp_path):
    """A bound shrunk 1e6x violates the error model; noise of 1e-7 under a small bound is a silent failure."""
    code = _run(
        [
            "--sweeps",
            "degenerate-su2,momenta-su2",
            "--workers",
            "1",
            "--out",
            str(tmp_path),
            "--implementation",
            f"tests.test_stress:{planted}",
        ]
    )
    rep = json.loads((tmp_path / "report.json").read_text())
    assert code == 1
    assert rep["summary"][what] > 0
    assert "FAIL" in (tmp_path / "report.md").read_text()


def test_flag_only_mode_flags_instead_of_escalating(tmp_path):
    """--no-escalate: points over the tolerance are flagged, none escalated, still no silent failure."""
    code = _run(
        [
            "--sweeps",
            "degenerate-su2",
            "--quick",
            "--no-escalate",
            "--workers",
            "1",
            "--out",
            str(tmp_path),
        ]
    )
    rep = json.loads((tmp_path / "report.json").read_text())
    rows = rep["sweeps"][0]["rows"]
    assert code == 0
    assert not any(r["escalated"] for r in rows)
    assert (
        sum(r["outcome"] == "flagged" for r in rows) >= 3 and rep["summary"]["silent_failures"] == 0
    )


@pytest.mark.parametrize(
    "argv",
    [
        ["--tol", "-1"],
        ["--sweeps", "no-such-sweep"],
        ["--implementation", "nocolon"],
        ["--judge-dps", "10"],
    ],
)
def test_bad_arguments_exit_2(argv, tmp_path, capsys):
    """Bad options are refused with a message on stderr and exit code 2, before any work."""
    assert _run([*argv, "--workers", "1", "--out", str(tmp_path)]) == 2
    assert "tstarg stress:" in capsys.readouterr().err


# --------------------------------------------------------------- Brouwer
def test_fit_exponent_recovers_half_on_a_random_walk():
    """RMS of 4000 Gaussian random walks ~ sqrt(t): the fitted exponent is 0.5 (independent check of the fit)."""
    rng = np.random.default_rng(2024)
    steps = rng.standard_normal((4000, 2000)).cumsum(axis=1)
    k = np.unique(np.round(np.logspace(1, np.log10(2000), 30)).astype(int))
    rms = np.sqrt(np.mean(steps[:, k - 1] ** 2, axis=0))
    p, c = _stress.fit_exponent(k.astype(float), rms)
    # sampling error of an RMS over M walks is ~1/sqrt(2M) = 1.1% per sample; over 2.3 decades the slope's
    # error is below 0.01: 0.03 is a 3-sigma-plus band
    assert abs(p - 0.5) <= 0.03 and abs(c - 1.0) <= 0.1


def test_fit_exponent_exact_power_laws():
    """Exact power laws c t^p are fitted to rounding (p = 1: a systematic drift; p = 0.5: Brouwer)."""
    t = np.logspace(0, 4, 25)
    for p_true, c_true in ((1.0, 3e-16), (0.5, 2e-16), (0.25, 1.0)):
        p, c = _stress.fit_exponent(t, c_true * t**p_true)
        # least squares on ~30 log values of size <= 40: rounding error ~ 1e3 eps
        assert (
            abs(p - p_true) <= 1e3 * np.finfo(float).eps
            and abs(c / c_true - 1) <= 1e4 * np.finfo(float).eps
        )


def test_fit_exponent_refuses_bad_data():
    """Non-positive errors and mismatched arrays are ValueErrors."""
    with pytest.raises(ValueError, match="positive"):
        _stress.fit_exponent([1.0, 2.0, 3.0], [1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="equal length"):
        _stress.fit_exponent([1.0, 2.0, 3.0], [1.0, 2.0])


def test_real_long_integration_follows_brouwer(quick_run):
    """DOP853 at h = 0.05 on the free rigid body: energy error ~ t^p with p near 1/2, round-off dominated."""
    _, _, rep = quick_run
    b = rep["brouwer"]
    # 16 trajectories over 2000 steps: the RMS of a random walk is estimated to ~18% per sample, which
    # leaves the slope over ~1.3 decades uncertain by ~0.1; a systematic drift would give p ~ 1
    assert 0.3 <= b["exponent"] <= 0.7, b["exponent"]
    # doubling the step: round-off predicts RMS(2h)/RMS(h) ~ 1/sqrt(2), truncation (order 8) 256
    assert b["truncation_check"]["ratio_2h_over_h"] < 4.0


def test_sweep_results_do_not_depend_on_where_they_ran():
    """The same sweep over 2 local processes gives exactly the serial rows (tasks deterministic in their item)."""
    from tstarg.reports._stress_run import run

    kw = {
        "quick": True,
        "tol": 1e-10,
        "escalate": True,
        "judge_dps": 50,
        "implementation": cmd_stress.DEFAULT_IMPLEMENTATION,
        "sweeps": ["degenerate-su2", "brouwer"],
        "brouwer_time": 20.0,
        "brouwer_trajectories": 8,
    }
    serial, pooled = run(workers=1, **kw), run(workers=2, **kw)

    def strip(rep):
        rows = [
            {k: v for k, v in r.items() if k != "seconds"} for s in rep["sweeps"] for r in s["rows"]
        ]
        return rows, rep["brouwer"]["rms"], rep["brouwer"]["exponent"]

    assert json.dumps(strip(serial), default=str) == json.dumps(strip(pooled), default=str)
