"""``tstarg bench``: the quick run writes sane reports; the Pareto front and the curve interpolation
agree with their definitions; a recorded error is recomputed by an independent route."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tstarg.reports import _workprecision as wp
from tstarg.reports import cli

EPS = np.finfo(float).eps
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    rc = cli.main(["bench", "--quick", "--out", str(out), "--workers", "1"])
    return rc, out, json.loads((out / "report.json").read_text())


def _dominated_brute(t, e):
    """Definition: i is dominated when some j has t_j <= t_i and e_j <= e_i with one strict."""
    n = len(t)
    return [
        any(t[j] <= t[i] and e[j] <= e[i] and (t[j] < t[i] or e[j] < e[i]) for j in range(n))
        for i in range(n)
    ]


def test_quick_run_writes_reports(quick_run, capsys):
    """The --quick CLI run exits 0 and writes report.json, report.md and every PNG it links."""
    rc, out, rep = quick_run
    assert rc == 0
    md = (out / "report.md").read_text()
    figures = (
        [f["figure"] for f in rep["flows"].values()]
        + rep["brackets"]["figures"]
        + [rep["batch"]["figure"]]
    )
    for fig in figures:
        assert (out / fig).read_bytes()[:8] == PNG, fig
        assert f"]({fig})" in md, f"{fig} not linked relatively from report.md"
    assert "heavy_top_wp.png" in figures and "free_top_wp.png" in figures
    assert "ratio tstarg / DOP853" in md and "Pareto" in md
    assert "serially in the main process" in md and "BLAS pinned to 1 thread" in md
    assert rep["environment"]["blas_threads"] and all(
        n == 1 for _, n in rep["environment"]["blas_threads"]
    )
    assert rep["command"].startswith("tstarg bench")


def test_quick_run_points_are_sane(quick_run):
    """Every flow point has a positive time and an error >= 0; the tstarg methods are those of METHODS
    that apply (minus RKMK on body systems); the scipy solvers are all there; on-front flags equal the
    brute-force definition over the recorded points; three error targets carry a ratio or a reason."""
    from tstarg.refimpl.flows import METHODS

    _, _, rep = quick_run
    for name, f in rep["flows"].items():
        pts = f["points"]
        model = wp.flow_problem(name, True).model()
        expected = {m for m, meth in METHODS.items() if meth.applies(model)[0] and not meth.rkmk}
        assert {p["method"] for p in pts if p["family"] == "tstarg"} == expected
        assert {p["method"] for p in pts if p["family"] == "scipy"} == {
            f"scipy {s}" for s in wp.SCIPY_SOLVERS
        }
        for p in pts:
            assert math.isfinite(p["time"]) and p["time"] > 0 and p["repeats"] >= 1
            assert (
                p["error"] is None or p["error"] >= 0
            )  # None: the run diverged (strict JSON has no inf)
        t = [p["time"] for p in pts]
        e = [math.inf if p["error"] is None else p["error"] for p in pts]
        brute = _dominated_brute(t, e)
        assert [p["on_front"] for p in pts] == [
            not d and math.isfinite(x) for d, x in zip(brute, e)
        ]
        assert [r["target"] for r in f["ratios"]][:3] == list(wp.ERROR_TARGETS)
        dop = [p["error"] for p in pts if p["method"] == "scipy DOP853"]
        assert f["ratios"][3]["target"] == min(dop)  # the extra row: at DOP853's finest error
        for r in f["ratios"]:
            assert (r["ratio_best_over_dop853"] is not None) != bool(r["note"])
            if r["ratio_best_over_dop853"] is not None:
                assert r["ratio_best_over_dop853"] == pytest.approx(
                    r["t_best"] / r["t_dop853"], rel=4 * EPS
                )
    for row in rep["brackets"]["summary"]:
        assert row["time_per_point"] > 0 and math.isfinite(row["error"])
    for row in rep["batch"]["rows"]:
        assert row["ratio"] == pytest.approx(
            row["ours_per_traj"] / row["scipy_per_traj"], rel=4 * EPS
        )


def test_recorded_fast_error_matches_closed_form(quick_run):
    """Free top: the recorded error of tstarg's dop853 at its finest rung equals the error recomputed
    here against Jacobi's elliptic-function solution evaluated by this test (mpmath at 30 digits)."""
    import mpmath

    from tstarg.refimpl.flows import euler_top_closed_form

    _, _, rep = quick_run
    p = wp.flow_problem("free_top", True)
    pt = max(
        (q for q in rep["flows"]["free_top"]["points"] if q["method"] == "dop853"),
        key=lambda q: q["setting"],
    )
    y = wp.run_fast(p, p.model(), "dop853", pt["setting"])[:, 0]
    with mpmath.workdps(30):
        exact = euler_top_closed_form([1, 2, 3], [mpmath.mpf(v) for v in p.pi0], p.T)
        err = float(max(abs(mpmath.mpf(float(a)) - b) for a, b in zip(y, exact)))
    # error model: the benchmark rounded the reference to float64 (<= eps/2 * |pi|, |pi| <= 3) and the
    # fixed-step run is deterministic, so the two errors differ by at most eps * max|pi|
    assert abs(err - pt["error"]) <= EPS * 3, (err, pt["error"])


def test_recorded_scipy_error_recomputed_independently(quick_run):
    """Heavy top: one recorded scipy DOP853 error equals the error of a solve_ivp run with a right-hand
    side written here from the Euler-Poisson equations (dpi/dt = pi x Omega + L x Gamma,
    dGamma/dt = Gamma x Omega, twee17 corrected, twee18), Gamma0 = R(x0)^T gamma from scipy's rotation
    vectors, judged against a fresh mpmath reference at 25 digits."""
    from scipy.integrate import solve_ivp
    from scipy.spatial.transform import Rotation

    from tstarg.refimpl import su2
    from tstarg.refimpl.flows import reference_trajectory

    _, _, rep = quick_run
    p = wp.flow_problem("heavy_top", True)
    pts = [q for q in rep["flows"]["heavy_top"]["points"] if q["method"] == "scipy DOP853"]
    pt = sorted(pts, key=lambda q: q["setting"])[len(pts) // 2]
    Iinv = 1 / np.diag(p.inertia)
    L = np.array(p.potential["L"])

    def rhs(t, y):
        pi, G = y[:3], y[3:]
        W = Iinv * pi
        return np.concatenate([np.cross(pi, W) + np.cross(L, G), np.cross(G, W)])

    G0 = Rotation.from_rotvec(p.x0).as_matrix().T @ np.array(p.potential["gamma"])
    sol = solve_ivp(
        rhs,
        (0, p.T),
        np.concatenate([p.pi0, G0]),
        method="DOP853",
        rtol=pt["setting"],
        atol=pt["setting"],
    )
    inertia = np.array(p.inertia)
    pot = {k: (np.array(v) if k != "kind" else v) for k, v in p.potential.items()}
    tr = reference_trajectory(
        su2(),
        np.zeros((3, 3)),
        np.zeros((3, 3)),
        inertia,
        pot,
        p.x0,
        p.pi0,
        [0, p.T],
        dps=25,
        system="body",
    )
    ref = np.array([float(v) for v in list(tr.pi[-1]) + list(tr.Gamma[-1])])
    err = float(np.max(np.abs(sol.y[:, -1] - ref)))
    # error model: the two right-hand sides agree to ~4 eps |y|^2 per evaluation; with the same accepted
    # steps the end states differ by at most c * eps * nfev * growth; growth <= 1e2 over t = 10 for this
    # regular (non-chaotic) top; the references' roundings (eps |y|) are far below that
    tol = 4 * EPS * sol.nfev * 1e2
    assert sol.nfev == pt["nfev"], (
        "a different accepted-step sequence: the comparison would be meaningless"
    )
    assert abs(err - pt["error"]) <= tol, (err, pt["error"], tol)


def test_reference_values_are_confirmed(quick_run):
    """The heavy top's stored reference end state agrees with a 25-digit reference computed here."""
    _, _, rep = quick_run
    vals = np.array([float(v) for v in rep["flows"]["heavy_top"]["reference"]["values"]])
    ref2 = wp.reference_task(("heavy_top", True, 25, False))
    other = np.array([float(v) for v in ref2["values"]])
    # error model: the 16-digit GBS reference is good to ~1e-16 relative (its tolerance 1e-21 per step
    # plus 15 guard digits), |y| <= 3: both roundings to float64 included, 8 eps * 3
    assert np.max(np.abs(vals - other)) <= 8 * EPS * 3


@given(st.lists(st.tuples(st.integers(1, 6), st.integers(1, 6)), min_size=1, max_size=25))
def test_pareto_front_matches_definition(pairs):
    """pareto_front marks exactly the points no other point dominates (ties in time or error included)."""
    t = [float(a) for a, _ in pairs]
    e = [10.0**-b for _, b in pairs]
    got = wp.pareto_front(t, e).tolist()
    assert got == [not d for d in _dominated_brute(t, e)]


def test_pareto_front_examples():
    """A worse-in-both point is off the front; an equal duplicate pair is on it; NaN never is."""
    assert wp.pareto_front([1, 2], [1e-3, 1e-2]).tolist() == [True, False]
    assert wp.pareto_front([1, 1], [1e-3, 1e-3]).tolist() == [True, True]
    assert wp.pareto_front([1, 2, 3], [1e-3, math.nan, 1e-5]).tolist() == [True, False, True]
    with pytest.raises(ValueError, match="same length"):
        wp.pareto_front([1, 2], [1.0])


def test_time_at_error_is_exact_on_power_laws():
    """On a power law t = a e^-b (a straight line in log-log) the interpolated time is the law itself;
    below the finest point it is 'not reached' (NaN); above the cheapest it is the cheapest time."""
    a, b = 3e-4, 1 / 8
    e = np.array([1e-2, 1e-5, 1e-8, 1e-11])
    t = a * e**-b
    for tgt in (1e-6, 1e-9, 3e-3):
        # error model: log/exp round-off, a few eps relative
        assert wp.time_at_error(t, e, tgt) == pytest.approx(a * tgt**-b, rel=16 * EPS)
    assert math.isnan(wp.time_at_error(t, e, 1e-12))
    assert wp.time_at_error(t, e, 0.5) == t[0]
    # a dominated point (slower and less accurate) does not bend the curve
    t2, e2 = np.append(t, 1.0), np.append(e, 1e-3)
    assert wp.time_at_error(t2, e2, 1e-6) == pytest.approx(a * 1e-6**-b, rel=16 * EPS)


@pytest.mark.parametrize(
    "argv, msg",
    [
        (["--problems", "spinning_plate"], "unknown flow problem"),
        (["--ref-dps", "5"], "--ref-dps must be >= 15"),
        (["--batch-method", "euler"], "unknown flow method"),
        (["--protocol-problems", "kirchhoff_se3,spinning_plate"], "unknown protocol problem"),
        (["--protocol-batch", "0"], "--protocol-batch must be at least 1 trajectory, got 0"),
        (["--protocol-batch", "-3"], "--protocol-batch must be at least 1 trajectory, got -3"),
    ],
)
def test_bad_arguments_exit_2(tmp_path, capsys, argv, msg):
    """Unknown problems, a too small reference precision or an empty protocol batch (was an IndexError
    from the batch's starting points) are refused with exit code 2 and a message."""
    rc = cli.main(["bench", "--quick", "--out", str(tmp_path)] + argv)
    assert rc == 2
    assert msg in capsys.readouterr().err


def test_error_ladders_do_not_depend_on_where_they_run():
    """The error ladders (deterministic tasks) are identical serially and over two local processes."""
    from tstarg.reports._parallel import map_tasks

    ref = wp.reference_task(("free_top", True, 20, False))["values"]
    items = [
        ("free_top", True, "fast", "dop853", wp.step_ladder(8, 13, 52), ref, 1e-11, 20000, 1e-3),
        ("free_top", True, "scipy", "DOP853", [1e-4, 1e-7], ref, 1e-11, 20000, 1e-3),
    ]
    serial = map_tasks(wp.ladder_task, items, workers=1)
    assert serial == map_tasks(wp.ladder_task, items, workers=2)
    assert [len(r["points"]) for r in serial] == [3, 2]


def test_time_points_counts_warmups_and_separates_clocks():
    """One untimed warm-up per group, then the stated repeats; a sleeping call costs wall time but
    (almost) no CPU time, so the two clocks are really different clocks."""
    import time as _time

    counts = [0, 0, 0]

    def make(i, pause):
        def fn():
            counts[i] += 1
            _time.sleep(pause)

        return fn

    res = wp.time_points(
        [make(0, 0.0), make(1, 0.0), make(2, 0.02)], groups=["a", "a", "b"], max_rounds=3
    )
    assert counts == [1 + 3, 3, 1 + 3]  # the group's first call is its warm-up
    assert [r["repeats"] for r in res] == [3, 3, 3]
    assert (
        res[2]["wall"] >= 0.02 and res[2]["time"] < 0.01
    )  # sleeping takes no CPU (generous 10 ms margin)


def test_modified_structure_problem_uses_general_methods():
    """With Upsilon != 0 (vier10/vier11 need Phi solves) the methods restricted to Upsilon = 0 are skipped
    with their reasons, scipy gets the numpy body field, and a DOP853 ladder reaches rtol-level error."""
    p = wp.flow_problem("modified_top", True)
    model = p.model()
    names, skipped = wp.fast_methods(model)
    assert "gauss6" in names and "dop853" in names
    assert "splitting4" in skipped and "Upsilon" in skipped["splitting4"]
    assert "numpy body field" in wp.scipy_rhs(model)[1]
    ref = wp.reference_task(("modified_top", True, 16, False))["values"]
    res = wp.ladder_task(
        ("modified_top", True, "scipy", "DOP853", [1e-4, 1e-8], ref, 1e-11, 20000, 1e-3)
    )
    e4, e8 = (q["error"] for q in res["points"])
    # DOP853's local error control: the global error over t = 10 follows rtol within a modest factor
    assert e8 < e4 and e8 <= 1e3 * 1e-8 and e4 <= 1e3 * 1e-4


# ------------------------------------------------------------------ --impl / --cmd contenders
@pytest.fixture(scope="module")
def impl_run(tmp_path_factory):
    """The quick bench with the plain first-principles implementation (reports.mutants:CORRECT,
    written independently of refimpl.fast; its flow takes steps=) as a contender."""
    out = tmp_path_factory.mktemp("bench_impl")
    argv = ["bench", "--quick", "--problems", "free_top", "--no-batch", "--no-heyoka"]
    argv += ["--impl", "tstarg.reports.mutants:CORRECT", "--out", str(out), "--workers", "1"]
    rc = cli.main(argv)
    return rc, out, json.loads((out / "report.json").read_text())


def test_impl_contender_appears_in_reports(impl_run):
    """The contender is in report.json (its points on the flow diagram, its bracket rows, ratios
    impl / ours at every error target it reaches) and in report.md's tables, by its name."""
    rc, out, rep = impl_run
    assert rc == 0
    name = "impl plain[correct]"
    assert rep["impl"]["name"] == "plain[correct]" and rep["impl"]["flow_setting"] == "steps"
    pts = [p for p in rep["flows"]["free_top"]["points"] if p["method"] == name]
    assert len(pts) >= 2 and all(p["family"] == "impl" and p["time"] > 0 for p in pts)
    reached = [r for r in rep["flows"]["free_top"]["ratios"] if r.get("t_impl")]
    assert reached and all(r["ratio_impl_over_ours"] > 0 for r in reached if r["t_best"])
    algebras = {r["algebra"] for r in rep["brackets"]["impl_ratios"]}
    assert algebras == {"su(2)", "se(3)"}
    md = (out / "report.md").read_text()
    assert "## Third-party implementation: plain[correct]" in md
    assert "ratio impl / ours" in md and "ratio impl / heyoka" in md and name in md


def test_impl_flow_errors_are_judged_and_show_rk4_order(impl_run):
    """Recorded contender errors agree with an independent judge (scipy DOP853 at rtol 1e-13 on the
    body system, not the closed form the bench uses) to within the judge's own error, and fall
    with the order of Plain's classical RK4 (slope >= 3.5 between doubling step counts)."""
    from scipy.integrate import solve_ivp

    from tstarg.reports.mutants import CORRECT

    _, _, rep = impl_run
    p = wp.flow_problem("free_top", True)
    F = p.model().body_rhs()
    sol = solve_ivp(
        lambda t, y: F(y[:, None])[:, 0], (0, p.T), p.y0(), method="DOP853", rtol=1e-13, atol=1e-13
    )
    judge = sol.y[:, -1]
    pts = sorted(
        (q for q in rep["flows"]["free_top"]["points"] if q["family"] == "impl"),
        key=lambda q: q["setting"],
    )
    for q in pts:
        x, pi = CORRECT.flow(*wp.impl_flow_args(p), steps=q["setting"])
        e = float(np.max(np.abs(wp.impl_body_state(p, x, pi) - judge)))
        # the two judges differ by the DOP853 judge's error: ~1e-13 per unit time over t = 10, x 10
        assert abs(e - q["error"]) <= 1e-10 + 1e-6 * q["error"], (q, e)
    errs = [q["error"] for q in pts if q["error"] > 1e-11]
    for a, b in zip(errs, errs[1:]):
        assert math.log2(a / b) >= 3.5, errs


def test_cmd_contender_runs_a_jsonl_program(tmp_path):
    """``--cmd`` with the JSON-lines test program (refimpl.fast behind the protocol): one point
    (its flow takes no steps), within fast's promised flow tolerance (1e-10, x 10 x scale |pi| ~ 2.3)."""
    import sys
    from pathlib import Path

    prog = Path(__file__).parent / "meta" / "jsonl_program.py"
    argv = ["bench", "--quick", "--problems", "free_top", "--no-batch", "--no-heyoka"]
    argv += ["--no-brackets", "--cmd", f"{sys.executable} {prog} --flow", "--out", str(tmp_path)]
    rc = cli.main([*argv, "--workers", "1"])
    assert rc == 0
    rep = json.loads((tmp_path / "report.json").read_text())
    pts = [p for p in rep["flows"]["free_top"]["points"] if p["family"] == "impl"]
    assert len(pts) == 1 and pts[0]["setting"] is None
    assert pts[0]["error"] is not None and pts[0]["error"] <= 10 * 1e-10 * 2.3
    assert "Third-party implementation" in (tmp_path / "report.md").read_text()


@pytest.mark.parametrize(
    "argv, msg",
    [
        (["--impl", "tstarg_no_such_module:impl"], "--impl 'tstarg_no_such_module:impl'"),
        (["--impl", "tstarg.reports.mutants:NO_SUCH"], "has no attribute 'NO_SUCH'"),
        (["--impl", "tests.meta.targets:not_an_implementation"], "provides neither flow nor"),
        (["--impl", "no-colon-here!"], "cannot import"),
        (["--cmd", "/nonexistent/program"], "--cmd '/nonexistent/program'"),
    ],
)
def test_bad_contender_fails_by_name(tmp_path, capsys, argv, msg):
    """An unimportable module, a missing object, an object without the timed methods or a program
    that does not start: exit 2, and the message names the spec."""
    rc = cli.main(["bench", "--quick", "--out", str(tmp_path / "o"), *argv])
    assert rc == 2
    err = capsys.readouterr().err
    assert msg in err, err
    assert not (tmp_path / "o").exists()  # nothing written, nothing run


def test_quick_run_races_the_batch_against_heyoka(quick_run):
    """With heyoka installed, the quick run times the largest batch against ``taylor_adaptive_batch``:
    heyoka, our adaptive ``taylor`` and the fixed-step batch method, each with its worst error against
    the heyoka judge at 1e-16; the adaptive contenders meet the target, the ratios are to heyoka."""
    pytest.importorskip("heyoka")
    rc, out, rep = quick_run
    b = rep["batch_heyoka"]
    assert rc == 0 and len(b["rows"]) == 3
    assert b["rows"][0]["ratio"] == 1.0 and "heyoka" in b["rows"][0]["label"]
    assert "taylor" in b["rows"][1]["label"]
    for r in b["rows"][:2]:
        assert math.isfinite(r["worst"]) and r["worst"] <= b["target"]
        assert r["per_traj"] > 0 and math.isfinite(r["ratio"])
    assert "Batch against heyoka" in (out / "report.md").read_text()


def test_heyoka_batch_and_asym_heavy_top_against_scipy():
    """``run_heyoka_batch`` (SIMD chunks, the last one padded) on 5 trajectories of the asymmetric heavy
    top, t = 10: within 1e-8 of scipy's DOP853 at rtol = atol = 1e-12 per trajectory (another
    integrator, its error ~1e-10 here), and the padded chunk returns exactly the trajectories asked for."""
    pytest.importorskip("heyoka")
    p = wp.flow_problem("asym_heavy_top", True)
    model = p.model()
    x0, pi0 = wp.batch_initial(p, 5, 3)
    Y0 = wp.scipy_initial(p, x0, pi0, 5)
    y = wp.run_heyoka_batch(p, model, 1e-13, Y0)
    assert y.shape == (6, 5)
    rhs = wp.scipy_rhs(model)[0]
    for j in range(5):
        sol = wp.run_scipy(p, rhs, "DOP853", 1e-12, Y0[:, j])
        assert np.max(np.abs(sol.y[:, -1] - y[:, j])) <= 1e-8


# ------------------------------------------------------------------ the protocol flow on every algebra
def test_quick_run_protocol_section_charges_heyoka_by_the_rule(quick_run):
    """The quick run's protocol section (bianchi_cocycle, T = 2): our error and time are recorded;
    every heyoka point timed sits on the quarter-decade grid 10^(-k/4) with an error at or below
    ours; the charged point is the fastest of them and the ratio is ours / its time; the batch too;
    report.md carries the summary table with the ratio."""
    pytest.importorskip("heyoka")
    rc, out, rep = quick_run
    pr = rep["protocol"]["problems"]["bianchi_cocycle"]
    o = pr["ours"]
    assert rc == 0 and o["time"] > 0 and 0 < o["error"] < 1e-6
    assert pr["heyoka"], "heyoka's grid reaches a 1e-10-level error"
    for h in pr["heyoka"]:
        k = -4 * math.log10(h["tol"])
        assert abs(k - round(k)) < 1e-9 and h["error"] <= o["error"]
    best = min(pr["heyoka"], key=lambda h: h["time"])
    assert pr["heyoka_best"] == best and pr["ratio"] == pytest.approx(o["time"] / best["time"])
    b = pr["batch"]
    assert b["M"] == 40 and b["heyoka_best"]["error"] <= b["ours"]["error"]
    assert b["ratio"] == pytest.approx(b["ours"]["time"] / b["heyoka_best"]["time"])
    md = (out / "report.md").read_text()
    assert "## Protocol flow on every algebra against heyoka" in md
    assert "| bianchi_cocycle | Bianchi VI0 (3) | 2 |" in md and "our first call" in md


def test_quick_run_protocol_judge_agrees_with_the_mpmath_reference_flow(quick_run):
    """The judge of the protocol section (heyoka real128 on the generated (pi, Ad(g)) system) agrees
    with the project's mpmath reference flow (vier10/vier11 in exponential coordinates, GBS at 20
    digits; no heyoka, no generated expression). Error model: the reference is good to ~1e-18; its x
    rounded to float64 moves Ad(exp x) by about |ad| eps ||Ad|| per entry, and scipy's expm adds
    ~n eps ||Ad||: 1e-12 max(1, max|R|) is slack by two orders and far below any wrong judge."""
    pytest.importorskip("heyoka")
    from scipy.linalg import expm

    from tstarg.refimpl.flows import reference_flow
    from tstarg.reports import _bench_protocol as bp

    _, _, rep = quick_run
    vals = np.array(
        [float(v) for v in rep["protocol"]["problems"]["bianchi_cocycle"]["reference"]["values"]]
    )
    p = bp.protocol_problem("bianchi_cocycle", True)
    x, pi = reference_flow(*p.args(), dps=20)
    x = np.array([float(v) for v in x])
    pi = np.array([float(v) for v in pi])
    R = expm(bp.ad_matrix(p.f, x)).ravel()
    scale = max(1.0, float(np.max(np.abs(vals[3:]))))
    assert np.max(np.abs(pi - vals[:3])) <= 1e-12 * scale
    assert np.max(np.abs(R - vals[3:])) <= 1e-12 * scale


def test_quick_report_states_ladders_in_their_units(quick_run):
    """Step counts for the fixed-step methods and tolerances for the adaptive ones, never a tolerance
    printed as a step count (the old "a geometric ladder from N0 = 1e-06")."""
    _, out, rep = quick_run
    md = (out / "report.md").read_text()
    for f in rep["flows"].values():
        lo, hi = f["ladder"]
        assert isinstance(lo, int) and isinstance(hi, int) and lo >= 4
        assert f"geometric ladder from {lo} to at most {hi} steps" in md
    assert "N0 = 1e" not in md and "over the tolerances 1e-06 to 1e-10" in md


def _inside(fig):
    """What the figure draws (each axes with its tick labels, labels and legend; the title) lies
    inside its canvas, and no legend covers an axes."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    W, H = fig.bbox.width, fig.bbox.height
    boxes = [ax.get_tightbbox(r) for ax in fig.axes]
    assert fig.get_suptitle(), "the title is the figure's, laid out inside it"
    boxes.append(fig._suptitle.get_window_extent(r))
    for bb in boxes:
        assert bb.x0 >= -1 and bb.y0 >= -1 and bb.x1 <= W + 1 and bb.y1 <= H + 1, (bb, W, H)
    for ax in fig.axes:
        lg = ax.get_legend()
        assert lg is not None
        assert not lg.get_window_extent(r).overlaps(ax.get_window_extent(r))


def test_bench_figures_keep_titles_and_legends_inside_and_off_the_data():
    """The work-precision and batch figures, drawn with a long title and many methods (the --impl
    case): the title and every label stay inside the canvas and the legend beside the axes."""
    import matplotlib.pyplot as plt

    title = "a long title " * 14
    pts = [
        {
            "method": f"method number {k}",
            "time": 10.0 ** (-k / 3 - j),
            "error": 10.0 ** (-j),
            "family": fam,
        }
        for k, fam in enumerate(["tstarg"] * 12 + ["scipy"] * 3 + ["impl"])
        for j in range(4)
    ]
    fig = wp.work_precision_figure(pts, title)
    _inside(fig)
    plt.close(fig)
    rows = [
        {
            "M": M,
            "ours_per_traj": 1e-5 / M,
            "scipy_per_traj": 1e-3,
            "ours_label": "ours " * 12,
            "scipy_label": "scipy DOP853 looped (rtol = atol = 1e-10)",
        }
        for M in (1, 100, 10000)
    ]
    fig = wp.batch_figure(rows, title)
    _inside(fig)
    plt.close(fig)


def test_reuse_takes_left_out_sections_from_an_earlier_run(quick_run, tmp_path):
    """``--reuse``: a run measuring nothing takes every section from the earlier report, copies its
    figures, and names the run each section came from; a missing file is refused with exit 2."""
    _, out, rep = quick_run
    argv = [
        "bench",
        "--quick",
        "--problems",
        "none",
        "--protocol-problems",
        "none",
        "--no-brackets",
    ]
    argv += ["--no-batch", "--out", str(tmp_path / "r"), "--workers", "1"]
    assert cli.main([*argv, "--reuse", str(out / "report.json")]) == 0
    new = json.loads((tmp_path / "r" / "report.json").read_text())
    assert new["flows"] == rep["flows"] and new["brackets"] == rep["brackets"]
    assert set(new["reused"]) >= {"flows", "brackets", "batch"}
    assert new["reused"]["flows"]["command"] == rep["command"]
    for f in rep["flows"].values():
        assert (tmp_path / "r" / f["figure"]).read_bytes()[:8] == PNG
    md = (tmp_path / "r" / "report.md").read_text()
    assert "section `flows` reused from an earlier run" in md
    assert cli.main([*argv, "--reuse", str(tmp_path / "nope.json")]) == 2
