"""Fast flows (numpy, batched) against the reference flow; batch consistency; structure of the splitting.

fast_flow promises |error| <= tol per trajectory (Richardson estimate with step doubling); checked
against the mpmath reference for the heavy top with re-basing, the gyrostat and Upsilon != 0.
"""

from __future__ import annotations

import numpy as np
import pytest

from tstarg.refimpl import catalogue, su2
from tstarg.refimpl.flows import (
    METHODS,
    NumpyModel,
    fast_flow,
    integrate_fast,
    reference_flow,
    reference_trajectory,
)

EPS = np.finfo(float).eps
F = su2()
I = np.diag([1.0, 1.3, 0.5])
POT = {"kind": "gravity", "L": np.array([0.1, 0.0, 1.0]), "gamma": np.array([0.0, 0.0, -1.0])}
XI = np.array([0.2, -0.1, 0.3])
THETA = -np.einsum("k,kab->ab", XI, F.f)
UPS = np.einsum("l,lmn->mn", np.array([0.05, 0.1, -0.08]), F.f)

CASES = {
    "heavy top": (np.zeros((3, 3)), np.zeros((3, 3)), POT),
    "gyrostat heavy top": (THETA, np.zeros((3, 3)), POT),
    "Upsilon != 0": (THETA, UPS, None),
}


@pytest.mark.parametrize("case", list(CASES))
def test_fast_flow_meets_tolerance_against_reference(case):
    """fast_flow(x0, pi0, t = 1) is within 10 tol (+ rounding 100 eps * steps) of reference_flow at 16 digits,
    including x after re-basing (recovered through the SU(2) representation)."""
    theta, ups, pot = CASES[case]
    x0, pi0 = np.array([0.5, 0.6, 0.3]), np.array([0.3, 0.2, 1.5])
    tol = 1e-9
    x, pi = fast_flow(F.f, theta, ups, I, pot, x0, pi0, 1.0, tol=tol)
    xr, pr = reference_flow(F.f, theta, ups, I, pot, x0, pi0, 1.0, dps=16)
    err = max(np.max(np.abs(x - xr)), np.max(np.abs(pi - pr)))
    # error model: promised truncation tol (x10 slack for the Richardson estimate) + rounding of
    # up to 2000 steps of O(1) numbers
    assert err <= 10 * tol + 100 * 2000 * EPS, err


def test_fast_flow_batched_shapes_and_consistency():
    """Leading batch axes are kept; each point of a (2, 2) batch equals its own single run
    (elementwise arithmetic: rounding differences only, 100 eps * steps)."""
    rng = np.random.default_rng(11)
    x0 = 0.3 * rng.normal(size=(2, 2, 3))
    pi0 = rng.normal(size=(2, 2, 3))
    x, pi = fast_flow(F.f, THETA, np.zeros((3, 3)), I, POT, x0, pi0, 1.0, steps=64)
    assert x.shape == pi.shape == (2, 2, 3)
    for idx in np.ndindex(2, 2):
        xs, ps = fast_flow(F.f, THETA, np.zeros((3, 3)), I, POT, x0[idx], pi0[idx], 1.0, steps=64)
        assert np.max(np.abs(xs - x[idx])) <= 100 * 64 * EPS * max(1, np.max(np.abs(xs)))
        assert np.max(np.abs(ps - pi[idx])) <= 100 * 64 * EPS * max(1, np.max(np.abs(ps)))


def test_generic_algebra_fast_flow_against_reference():
    """A solvable algebra (Bianchi III) with a non-trivial cocycle: fast (x, pi) == reference within tol."""
    alg = catalogue("Bianchi III")
    theta = np.array([[0.0, 0.5, 0.0], [-0.5, 0.0, 0.0], [0.0, 0.0, 0.0]])
    I3 = np.diag([1.0, 1.5, 2.0])
    x0, pi0 = np.array([0.1, -0.2, 0.05]), np.array([0.3, 0.2, -0.4])
    x, pi = fast_flow(alg, theta, np.zeros((3, 3)), I3, None, x0, pi0, 1.0, tol=1e-10)
    xr, pr = reference_flow(alg.f, theta, np.zeros((3, 3)), I3, None, x0, pi0, 1.0, dps=16)
    assert max(np.max(np.abs(x - xr)), np.max(np.abs(pi - pr))) <= 10 * 1e-10 + 100 * 1000 * EPS


def test_splitting_keeps_group_element_unitary():
    """The Lie-Poisson splitting moves g by exact exponentials: the unit quaternion keeps |q| = 1 to
    rounding (error model: 8 eps per step)."""
    model = NumpyModel(F, THETA, np.zeros((3, 3)), I, POT)
    out = integrate_fast(
        model,
        METHODS["splitting4"],
        np.array([[0.5], [0.6], [0.3]]),
        np.array([[0.3], [0.2], [1.5]]),
        50.0,
        1000,
        system="full",
    )
    assert abs(np.sum(out["quat"] ** 2) - 1) <= 8 * 1000 * 3 * EPS


def test_scalar_dop853_equals_numpy_dop853():
    """The generated scalar DOP853 performs the same method as the numpy one (rounding only:
    100 eps * steps * scale)."""
    for alg, theta in (
        (F, THETA),
        (catalogue("Bianchi III"), np.array([[0, 0.5, 0], [-0.5, 0, 0], [0, 0, 0.0]])),
    ):
        model = NumpyModel(alg, theta, np.zeros((3, 3)), I, POT)
        x0, pi0 = np.array([[0.1], [0.2], [0.0]]), np.array([[0.3], [0.2], [1.5]])
        a = integrate_fast(model, METHODS["dop853"], x0, pi0, 5.0, 200, system="body")
        b = integrate_fast(model, METHODS["dop853-scalar"], x0, pi0, 5.0, 200, system="body")
        scale = max(1.0, float(np.max(np.abs(a["pi"]))))
        assert np.max(np.abs(a["pi"] - b["pi"])) <= 100 * 200 * EPS * scale
        assert np.max(np.abs(a["Gamma"] - b["Gamma"])) <= 100 * 200 * EPS * scale


def _su2_heavy_rhs(model, y):
    """su(2) Euler-Poisson with Theta by hand: ``pidot = pi' x W + L x G``, ``Gdot = G x W`` with
    ``W = I^-1 pi``, ``pi' = pi + xi`` and ``Theta_ab = -xi_k eps_kab`` (drie7, twee17-18)."""
    th = model.theta
    xi = -np.array([th[1, 2], th[2, 0], th[0, 1]])
    p, G = y[:3], y[3:]
    W = model.Iinv @ p
    Lv = model.Lvec[:, None]
    pidot = np.cross(p + xi[:, None], W, axis=0) + np.cross(Lv, G, axis=0)
    return np.concatenate([pidot, np.cross(G, W, axis=0)])


def test_generated_rhs_equals_hand_written_and_generic():
    """Three routes to the Euler-Poisson field agree: generated straight-line code, the hand-written
    su(2) cross products, and the generic einsum formulas of vier10/vier11 (error model 8 eps * scale^2)."""
    from tstarg.refimpl.flows import numpy_rhs

    model = NumpyModel(F, THETA, np.zeros((3, 3)), I, POT)
    y = np.random.default_rng(5).normal(size=(6, 40))
    gen = numpy_rhs(model)(y)
    hand = _su2_heavy_rhs(model, y)
    Omega, pidot = model.omega_pidot(y[:3], y[3:])
    generic = np.concatenate([pidot, model.gamma_dot(Omega, y[3:])])
    scale = np.max(np.abs(y)) ** 2 + 1
    assert np.max(np.abs(gen - hand)) <= 8 * EPS * scale
    assert np.max(np.abs(gen - generic)) <= 8 * EPS * scale


def test_rebased_x_recovered_through_representation_non_compact():
    """Bianchi V (solvable, class B): after several re-basings x(t) is recovered from the matrix
    representation and matches the reference's x within the flow tolerance (10 tol + rounding)."""
    alg = catalogue("Bianchi V")
    I3, Z = np.diag([1.0, 1.5, 2.0]), np.zeros((3, 3))
    x0, pi0 = np.array([0.9, -0.6, 0.3]), np.array([2.0, 1.5, -1.0])
    x, pi = fast_flow(alg, Z, Z, I3, None, x0, pi0, 1.0, tol=1e-10)
    tr = reference_trajectory(alg, Z, Z, I3, None, x0, pi0, [1.0], dps=16)
    assert tr.rebases >= 1
    xr = np.array([float(v) for v in tr.x[-1]])
    scale = max(1.0, float(np.max(np.abs(xr))))
    # error model: tol (x10) on O(1) state, times |x| for the log map, + 1000 eps * scale rounding
    assert np.max(np.abs(x - xr)) <= 10 * 1e-10 * scale + 1000 * EPS * scale


def test_scalar_rhs_list_and_array_equal_numpy_rhs():
    """The generated scalar rhs (for scipy baselines) gives the same field for a list and for an ndarray
    argument (converted to Python floats), equal to the numpy rows version (error model 8 eps * scale^2)."""
    from tstarg.refimpl.flows import numpy_rhs, scalar_rhs

    model = NumpyModel(F, THETA, np.zeros((3, 3)), I, POT)
    y = np.random.default_rng(8).normal(size=6)
    a = scalar_rhs(model)(0.0, y)
    b = scalar_rhs(model)(0.0, y.tolist())
    assert all(type(v) is float for v in a)
    assert a == b
    scale = np.max(np.abs(y)) ** 2 + 1
    assert np.max(np.abs(np.array(a) - numpy_rhs(model)(y[:, None])[:, 0])) <= 8 * EPS * scale


@pytest.mark.skipif(
    not __import__("tstarg.refimpl._compiled_taylor", fromlist=["x"]).HAVE_NUMBA,
    reason="numba not importable: the planner keeps the fixed-step methods",
)
@pytest.mark.parametrize("outputs", [["pi", "energy"], ["pi", "x"]], ids=["body", "full"])
def test_planner_picks_adaptive_taylor_and_samples_meet_tol(outputs):
    """A Lagrange-top scene (Upsilon = 0, two trajectories, t = 3, 4 samples, tol 1e-9; the model of
    tests/test_compiled_taylor.py, so the kernels compiled there are reused): the planner
    chooses the compiled adaptive Taylor method and says so; every sample of ``pi`` is within tol of
    the mpmath reference trajectory (GBS at 30 digits; an independent route)."""
    from tstarg.refimpl.scenes import parse_scene, plan, run_scene

    sc = parse_scene(
        {
            "algebra": "su(2)",
            "inertia_diagonal": [1.0, 1.0, 0.5],
            "potential": {"L": [0.0, 0.0, 1.0], "gamma": [0.0, 0.0, -1.0]},
            "x0": [[0.1, 0.2, 0.0], [0.3, -0.1, 0.2]],
            "pi0": [[0.3, 0.2, 2.0], [0.1, 0.5, -1.0]],
            "t_end": 3.0,
            "samples": 4,
            "tol": 1e-9,
            "outputs": outputs,
        }
    )
    p = plan(sc)
    assert p.method == "taylor" and "adaptive" in p.describe()
    out = run_scene(sc, p)
    assert out["pi"].shape == (4, 2, 3)
    for j in range(2):
        tr = reference_trajectory(
            F,
            np.zeros((3, 3)),
            np.zeros((3, 3)),
            np.diag([1.0, 1.0, 0.5]),
            sc.potential,
            sc.x0[j],
            sc.pi0[j],
            [0.0, 1.0, 2.0, 3.0],
            dps=30,
            system="body",
        )
        want = np.array([[float(v) for v in row] for row in tr.pi])
        err = np.max(np.abs(out["pi"][:, j] - want))
        assert np.isfinite(err) and err <= sc.tol, err


@pytest.mark.parametrize("t", [100.0, -3.0])
def test_one_trajectory_call_refuses_too_fast_points_as_the_batch(t):
    """The protocol call of one trajectory (1-D points: ``_fast._flow_one``, whose rates check runs only
    above a per-model bound on ``max |pi|``) refuses a point rotating too fast for the step budget with
    the batch's message (refimpl._validate.check_flow_rates: ``|t| ||I^-1|| |pi| > 2^14 (2 + |t|)``;
    here ``||I^-1|| = 2``, ``|pi| sqrt 3 = 1.7e7``), and flows the same point scaled below the bound."""
    x0 = np.array([0.1, 0.2, 0.0])
    fast = np.array([0.0, 0.0, 1e7])
    for a, b in ((x0, fast), (x0[None], fast[None])):
        with pytest.raises(ValueError, match="rotates too fast for the flow budget"):
            fast_flow(F.f, np.zeros((3, 3)), np.zeros((3, 3)), I, POT, a, b, t)
    x, pi = fast_flow(F.f, np.zeros((3, 3)), np.zeros((3, 3)), I, POT, x0, fast * 1e-7, t)
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(pi))


def test_load_point_copies_the_start_and_refuses_unbounded_entries():
    """``_flow_checks.load_point`` (compiled) and its plain-Python twin: ``max |pi0|`` with ``x0``,
    ``pi0`` copied into the columns of ``X``, ``P`` when every entry is finite with ``|v| <= bound``
    (the bound itself included, -0.0 read as 0), else -1.0, for NaN, +-inf and ``|v|`` past the bound
    in either array; a strided and a read-only ``x0`` are read as their values."""
    from tstarg.refimpl._flow_checks import _load_point_py, load_point

    x0 = np.array([0.5, -2.0, 1e300])
    pi0 = np.array([-3.0, 0.25, -0.0])
    strided = np.repeat(x0, 2)[::2]
    frozen = x0.copy()
    frozen.flags.writeable = False
    for fn in (load_point, _load_point_py):
        for xa in (x0, strided, frozen):
            X, P = np.full((3, 1), 7.0), np.full((3, 1), 7.0)
            assert fn(xa, pi0, X, P, 1e300) == 3.0
            assert np.array_equal(X[:, 0], x0) and np.array_equal(P[:, 0], pi0)
        for bad in (np.nan, np.inf, -np.inf, -1.0000000000000001e301):
            for k in range(3):
                xb, pb = x0.copy(), pi0.copy()
                xb[k] = bad
                assert fn(xb, pi0, np.empty((3, 1)), np.empty((3, 1)), 1e300) == -1.0
                pb[k] = bad
                assert fn(x0, pb, np.empty((3, 1)), np.empty((3, 1)), 1e300) == -1.0


@pytest.mark.parametrize("name", ["h(3)", "su(2)"])
def test_one_trajectory_call_reads_any_1d_layout_and_refuses_bad_points_by_name(name):
    """The protocol call of one trajectory (1-D points, ``_fast._flow_one``: the start copied into
    work arrays kept per model) gives bit for bit the same answer for a contiguous, a strided and a
    read-only start, leaves them unchanged, and refuses NaN, inf and |v| > 1e300 in ``x0`` or ``pi0``
    with the batch's messages (``refimpl._validate.check_points``)."""
    alg = catalogue(name)
    z = np.zeros((3, 3))
    args = (alg.f, z, z, np.diag([1.0, 1.7, 2.3]), None)
    x0, pi0 = np.array([0.1, -0.2, 0.3]), np.array([0.4, 0.5, -0.6])
    x, pi = fast_flow(*args, x0, pi0, 1.5)
    frozen = x0.copy()
    frozen.flags.writeable = False
    for xa, pa in ((np.repeat(x0, 3)[::3], np.repeat(pi0, 2)[::2]), (frozen, pi0), (x0, pi0)):
        keep = (xa.copy(), pa.copy())
        xo, po = fast_flow(*args, xa, pa, 1.5)
        assert np.array_equal(xo, x) and np.array_equal(po, pi)
        assert np.array_equal(xa, keep[0]) and np.array_equal(pa, keep[1])
        assert not (np.shares_memory(xo, x) or np.shares_memory(po, pi))
    for bad, msg in ((np.nan, "NaN or infinity"), (-np.inf, "NaN or infinity"), (2e300, "beyond")):
        for which in ("x", "pi"):
            xb, pb = x0.copy(), pi0.copy()
            (xb if which == "x" else pb)[1] = bad
            with pytest.raises(ValueError, match=rf"^{which} .*{msg}"):
                fast_flow(*args, xb, pb, 1.5)


@pytest.mark.parametrize("name", ["h(3)", "su(2)"])
def test_one_trajectory_calls_from_threads_return_the_same_fresh_answers(name):
    """Calls of one trajectory from four threads at once (the compiled kernels release the GIL; each
    call takes its own work arrays from the runner's pool, or new ones when none is free) return bit
    for bit the single call's answer, in arrays no other call returns."""
    from concurrent.futures import ThreadPoolExecutor

    alg = catalogue(name)
    z = np.zeros((3, 3))
    args = (alg.f, z, z, np.diag([1.0, 1.7, 2.3]), None)
    rng = np.random.default_rng(5)
    starts = [(0.3 * rng.standard_normal(3), rng.standard_normal(3)) for _ in range(4)]
    want = [fast_flow(*args, x0, pi0, 2.0) for x0, pi0 in starts]

    def calls(k):
        x0, pi0 = starts[k]
        return [fast_flow(*args, x0, pi0, 2.0) for _ in range(40)]

    with ThreadPoolExecutor(4) as ex:
        got = list(ex.map(calls, range(4)))
    seen = []
    for k, outs in enumerate(got):
        for x, pi in outs:
            assert np.array_equal(x, want[k][0]) and np.array_equal(pi, want[k][1])
            seen += [x, pi]
    assert len({id(a.base if a.base is not None else a) for a in seen}) == len(seen)


def test_su2_start_read_from_1d_points_is_the_batch_start():
    """``_flow_compiled._load_start`` (the su(2) runner's start, read from the caller's 1-D points in
    one compiled call) writes bit for bit the row of ``_start`` (the batch's, from (3, 1) columns), with
    and without gravity, for a strided start too, and returns ``max |pi0|``; -1.0 and nothing used
    where an entry is NaN, infinite or past the bound."""
    from tstarg.refimpl._flow_compiled import _load_start, _start

    rng = np.random.default_rng(3)
    gamma = np.array([0.1, -0.4, 0.9])
    for grav, d in ((True, 10), (False, 7)):
        for _ in range(5):
            x0, pi0 = 2.0 * rng.standard_normal(3), rng.standard_normal(3)
            want = np.empty((1, d))
            _start(x0[:, None].copy(), pi0[:, None].copy(), gamma, grav, want)
            for xa in (x0, np.repeat(x0, 2)[::2]):
                got = np.full((1, d), np.nan)
                assert _load_start(xa, pi0, gamma, grav, got, 1e300) == np.max(np.abs(pi0))
                assert np.array_equal(got, want)
        for bad in (np.nan, np.inf, 2e300):
            xb = np.array([0.1, bad, 0.2])
            assert _load_start(xb, np.ones(3), gamma, grav, np.empty((1, d)), 1e300) == -1.0
            assert _load_start(np.ones(3), xb, gamma, grav, np.empty((1, d)), 1e300) == -1.0


@pytest.mark.parametrize("t", [100.0, -3.0])
def test_one_trajectory_call_off_su2_refuses_too_fast_points_as_the_batch(t):
    """As the su(2) test above on h(3) (the generic runner, ``_full_state.one_trajectory``, whose rates
    check runs inside the runner above the per-model bound): the batch's message for a point rotating
    too fast (``||I^-1|| = 2``, ``|pi| = 1e7``), and the same point scaled below the bound flows."""
    alg = catalogue("h(3)")
    z = np.zeros((3, 3))
    x0 = np.array([0.1, 0.2, 0.0])
    fast = np.array([0.0, 0.0, 1e7])
    for a, b in ((x0, fast), (x0[None], fast[None])):
        with pytest.raises(ValueError, match="rotates too fast for the flow budget"):
            fast_flow(alg.f, z, z, I, None, a, b, t)
    x, pi = fast_flow(alg.f, z, z, I, None, x0, fast * 1e-7, t)
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(pi))


def test_su2_finish_of_one_pair_checks_steps_and_finiteness():
    """``_flow_compiled._finish_one`` (the su(2) runner's one compiled call after the pair) and its
    plain-Python twin: ``_finish``'s estimate and logarithm (bit for bit compiled; the twin's numpy
    sqrt/arctan2 within 8 eps of |x| <= 2 pi, 4 eps of the estimate), ``B``'s ``pi``, and the verdict:
    0 where the first pair's estimate ``d`` (``min(d, prop d)`` for a factor ``prop > 0`` while ``d <=
    PROP_MAX_D``, else ``d``) is at most ``tol``, 3 where it is over; 1 where either run's step count is
    negative (a diverged run); 2 where ``B``'s ``pi`` or the logarithm ``x`` is not finite."""
    from tstarg.refimpl._flow_compiled import PROP_MAX_D, _finish, _finish_one, _finish_one_py

    rng = np.random.default_rng(4)
    q = rng.standard_normal(4)
    B = np.concatenate([rng.standard_normal(3), q / np.linalg.norm(q)])[None]
    A = B + 1e-9 * rng.standard_normal(B.shape)
    est0, x0 = np.empty(1), np.empty((3, 1))
    _finish(A, B, 3, est0, x0)
    d = float(est0[0])
    assert 0.0 < d <= PROP_MAX_D
    ok, bad = np.array([5]), np.array([-1])
    for fn in (_finish_one, _finish_one_py):
        est, x, pi = np.empty(1), np.empty(3), np.empty(3)
        assert fn(A, B, 3, est, x, pi, ok, ok, 0.0, np.inf) == 0
        if fn is _finish_one:
            assert np.array_equal(est, est0) and np.array_equal(x, x0[:, 0])
        np.testing.assert_allclose(x, x0[:, 0], rtol=0, atol=8 * EPS * 2 * np.pi)
        np.testing.assert_allclose(est, est0, rtol=4 * EPS, atol=0)
        assert np.array_equal(pi, B[0, :3])
        # the verdict: d itself (prop 0), or d scaled by prop = 1e-3 (under PROP_MAX_D)
        assert fn(A, B, 3, est, x, pi, ok, ok, 0.0, 2 * d) == 0
        assert fn(A, B, 3, est, x, pi, ok, ok, 0.0, d / 2) == 3
        assert fn(A, B, 3, est, x, pi, ok, ok, 1e-3, d / 2) == 0
        assert fn(A, B, 3, est, x, pi, ok, ok, 1e-3, d / 1e4) == 3
        Af = B.copy()  # |A - B| over PROP_MAX_D: the proportional form no longer applies
        Af[0, 0] += 10 * PROP_MAX_D
        assert fn(Af, B, 3, est, x, pi, ok, ok, 1e-6, 5 * PROP_MAX_D) == 3
        assert fn(Af, B, 3, est, x, pi, ok, ok, 1e-6, 20 * PROP_MAX_D) == 0
        assert fn(A, B, 3, est, x, pi, bad, ok, 0.0, np.inf) == 1
        assert fn(A, B, 3, est, x, pi, ok, bad, 0.0, np.inf) == 1
        for k, v in ((1, np.nan), (2, np.inf), (4, np.nan)):  # pi entries, then the quaternion
            Bb = B.copy()
            Bb[0, k] = v
            assert fn(A, Bb, 3, np.empty(1), np.empty(3), np.empty(3), ok, ok, 0.0, np.inf) == 2


def test_full_state_floor_of_one_trajectory_is_inf_for_an_unknown_size():
    """``_full_state._floor_one`` (the rounding floor of one trajectory's answer): inf where the
    answer's size is NaN or inf (Python's ``max(1.0, nan)`` is 1.0, which would let such an answer
    pass), else ``eps (4 (sqrt(steps) + n) max(1, size) + 30 kappa) + resid`` (ROUND_PER_STEP = 4,
    ROUND_AMPLIFIED = 30), written out here."""
    from tstarg.refimpl._full_state import _floor_one

    for size in (np.nan, np.inf):
        assert _floor_one(16, 3, size, 1.0, 0.0) == np.inf
    got = _floor_one(16, 3, 2.5, 7.0, 1e-14)
    want = EPS * (4.0 * (4.0 + 3) * 2.5 + 30.0 * 7.0) + 1e-14
    assert abs(got - want) <= 4 * EPS * want
    assert _floor_one(9, 3, 0.5, 0.0, 0.0) == EPS * 4.0 * (3.0 + 3)


def test_so5_one_trajectory_on_its_generated_kernel_agrees_with_the_shared_kernel(monkeypatch):
    """so(5) (660 Cauchy products, under ``_full_state.GENERATED_MAX_PRODUCTS``): the protocol call of
    one trajectory runs the structure's generated kernels (the pair, ``_pair_of``) and returns bit for
    bit ``full_state_flow``'s answer; the kernel compiled for every structure (tables, another
    implementation: ``GENERATED_MAX_PRODUCTS = 0``) gives ``pi`` and ``Ad(g)`` within the sum of the two
    answers' error estimates (each bounds its own error)."""
    from tstarg.refimpl import _full_state as fs_mod
    from tstarg.refimpl.flows import cached_model
    from tstarg.refimpl.flows._common import _AbelianPart

    basis = []  # so(5): E_ij = e_i e_j^T - e_j e_i^T (i < j); f[k, a, b]: [E_a, E_b] = f^k_ab E_k
    for i in range(5):
        for j in range(i + 1, 5):
            E = np.zeros((5, 5))
            E[i, j], E[j, i] = 1.0, -1.0
            basis.append(E)
    n = len(basis)
    M = np.array([E.ravel() for E in basis]).T
    f = np.zeros((n, n, n))
    for a in range(n):
        for b in range(n):
            f[:, a, b] = np.linalg.lstsq(M, (basis[a] @ basis[b] - basis[b] @ basis[a]).ravel())[0]
    f = np.round(f)  # the constants are 0, +-1: exact
    rng = np.random.default_rng(12)
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    inertia = Q @ np.diag(rng.uniform(1.0, 3.0, n)) @ Q.T
    x0, pi0 = 0.3 * rng.standard_normal(n), rng.standard_normal(n)
    z = np.zeros((n, n))
    model = cached_model(f, z, z, inertia, None)
    assert 400 < fs_mod.full_state(model, _AbelianPart).n_products <= fs_mod.GENERATED_MAX_PRODUCTS
    x, pi = fast_flow(f, z, z, inertia, None, x0, pi0, 0.5)
    gen = fs_mod.full_state_flow(model, x0[:, None], pi0[:, None], 0.5, 1e-10, abelian=_AbelianPart)
    assert np.array_equal(x, gen["x"][:, 0]) and np.array_equal(pi, gen["pi"][:, 0])
    monkeypatch.setattr(fs_mod, "GENERATED_MAX_PRODUCTS", 0)
    shared = fs_mod.full_state_flow(
        model, x0[:, None], pi0[:, None], 0.5, 1e-10, abelian=_AbelianPart
    )
    bound = gen["error_estimate"][0] + shared["error_estimate"][0]
    assert np.isfinite(bound) and bound <= 2e-10
    assert np.max(np.abs(gen["pi"] - shared["pi"])) <= bound
    assert np.max(np.abs(gen["Ad"] - shared["Ad"])) <= bound


def test_log_complete_keeps_an_unknown_residual_of_a_finite_x_infinite(monkeypatch):
    """``_full_state._log_complete``: where the logarithm's residual comes out NaN or inf, a row whose
    ``x`` is finite gets residual inf (its estimate can never pass) and only a row without a logarithm
    (``x`` not finite, refused by name after the control) gets 0; finite residuals are kept."""
    from tstarg.refimpl import _full_state as fs_mod
    from tstarg.refimpl.flows import cached_model
    from tstarg.refimpl.flows._common import _AbelianPart

    alg = catalogue("so(4)")  # not exponential: no abelian step
    z = np.zeros((6, 6))
    fs = fs_mod.full_state(
        cached_model(alg.f, z, z, np.diag(np.arange(1.0, 7.0)), None), _AbelianPart
    )
    assert fs.abelian is None

    def residual(xs, mats, proj, cplx, Ad, resid):
        resid[:] = [np.nan, np.inf, 3e-15, np.nan]

    monkeypatch.setattr(fs_mod._fk, "log_residual", residual)
    xs = np.zeros((4, 6))
    xs[3, 2] = np.nan
    resid = np.empty(4)
    B = np.zeros((4, fs.d))
    G = np.zeros((4, fs.r, fs.r), dtype=fs.mats.dtype)
    fs_mod._log_complete(fs, B, G, np.zeros((4, 6, 6)), xs, np.ones(4, np.bool_), resid)
    assert resid.tolist() == [np.inf, np.inf, 3e-15, 0.0]


@pytest.mark.parametrize("N", [1, 2])
def test_control_with_an_infinite_estimate_ends_without_floating_point_errors(N):
    """``_flow_compiled._control`` whose runs measure ``|A - B| = inf`` and a floor of inf (a row that
    can never pass) tightens to its floor and returns the estimate inf -- under
    ``np.errstate(all="raise")`` too (no ``inf - inf`` on the way)."""
    from tstarg.refimpl import _flow_compiled as fc

    def run(y, t, eps, order=None):
        return y.copy(), np.full(y.shape[0], 3, dtype=np.int64)

    def estimate(A, B, n, out):
        out[:] = np.inf

    def floor(B, steps, kappa, rows):
        return np.full(B.shape[0], np.inf)

    with np.errstate(all="raise"):
        _, est, _ = fc._control(
            None, np.zeros((N, 7)), 1.0, 1e-6, 3, 1e-10, runner=(run, lambda e: 16),
            estimate=estimate, floor=floor, reuse_last=True,
        )  # fmt: skip
    assert est.shape == (N,) and np.all(est == np.inf)
