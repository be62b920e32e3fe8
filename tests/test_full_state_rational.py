"""The compiled full-state Taylor flow with ``Upsilon != 0`` on every algebra (issue 25;
refimpl._full_state_rational).

Definition checked: the state ``(pi, [Gamma,] G = rho(g))`` under vier10/vier11 (``Psi Omega = dK -
Upsilon dV``, ``Phi pidot = -dV - S dK``, ``dG/dt = G rho(Omega)``), integrated by the series recurrence
of the solve by ``Phi``, with ``x(t)`` the project's logarithm of ``g(t)``; it is the default full-state
method off su(2) when ``Upsilon != 0``; the degenerate set ``Delta = det Phi = 0`` (vier12) is refused
by name.

Independent routes: the mpmath reference flow (its own field with mpmath matrix solves, in the chart
``(x, pi)`` with re-basing, Gragg-Bulirsch-Stoer at ``dps`` digits); for su(3) in the default run the
numpy Gauss6 flow (``np.linalg.solve`` per stage, re-based chart, step doubling to its tolerance);
for the degenerate set a closed form on aff(1) (below).

Error model of a flow against a reference: the two-run control promises ``tol`` per trajectory on
``pi`` and ``Ad(g)`` (an estimate, not a bound: ``K = 100`` as in tests/test_compiled_any_algebra.py),
plus the rounding of the solve by ``Phi`` at every coefficient, ``c n eps cond(Phi)`` (``c = 10^3``: the
growth over the few hundred coefficient solves of these short runs), scaled by ``max(1, |ref|)``; a
second route with its own tolerance ``tol_ref`` adds ``tol_ref``. ``x`` is compared to 9 significant
digits (``cond(log) <= 10`` away from the cut locus on these short trajectories).
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import scipy.linalg

from tstarg.refimpl import _full_state_rational as fr
from tstarg.refimpl._catalogue import bianchi, catalogue
from tstarg.refimpl._cohomology import cocycle_basis
from tstarg.refimpl._errors import DegeneratePointError
from tstarg.refimpl.flows import cached_model, fast_flow, reference_flow
from tstarg.refimpl.flows._common import _AbelianPart
from tstarg.refimpl.flows.registry import choose

EPS = np.finfo(float).eps
K = 100.0
needs_numba = pytest.mark.skipif(not fr._ct.HAVE_NUMBA, reason="numba not importable")


def _model(name, seed=0, grav=False, ups=0.05):
    """(algebra, Theta, Upsilon, inertia, potential, x0, pi0): a random antisymmetric ``Upsilon``
    (entries ``ups N(0,1)``, small enough to keep ``Delta`` away from 0 on these short runs) and a
    random ``Theta`` (a coboundary ``-xi.f``, or a cocycle of the solvable algebra)."""
    rng = np.random.default_rng(seed + 31)
    if name == "Bianchi III + cocycle":
        alg = bianchi("III")
        n = 3
        theta = np.asarray(
            sum(c * b for c, b in zip(rng.standard_normal(3), cocycle_basis(alg, exact=False))),
            float,
        )
    else:
        alg = catalogue(name)
        n = alg.f.shape[0]
        theta = -np.einsum("k,kab->ab", 0.3 * rng.standard_normal(n), np.asarray(alg.f, float))
    B = ups * rng.standard_normal((n, n))
    A = rng.standard_normal((n, n))
    inertia = A @ A.T / n + np.eye(n)
    pot = (
        {"kind": "gravity", "L": 0.3 * rng.standard_normal(n), "gamma": rng.standard_normal(n)}
        if grav
        else None
    )
    return alg, theta, B - B.T, inertia, pot, 0.2 * rng.standard_normal(n), rng.standard_normal(n)


def _ad(f, x):
    return scipy.linalg.expm(np.einsum("a,mab->mb", np.asarray(x, float), np.asarray(f, float)))


def _cond_phi(args, pi) -> float:
    alg, theta, ups = args[0], args[1], args[2]
    S = np.einsum("m,mab->ab", np.asarray(pi, float), np.asarray(alg.f, float)) - theta
    return float(np.linalg.cond(np.eye(len(pi)) + S @ ups))


def _compare(args, x, pi, xr, pir, tol, tol_ref=0.0):
    f = np.asarray(args[0].f, float)
    n = f.shape[0]
    cond = max(_cond_phi(args, args[6]), _cond_phi(args, pir))
    allow = K * tol + tol_ref + 1e3 * n * EPS * cond
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(pi))
    assert np.max(np.abs(pi - pir)) <= allow * max(1.0, np.max(np.abs(pir))), (pi, pir)
    Ad, Adr = _ad(f, x), _ad(f, xr)
    assert np.max(np.abs(Ad - Adr)) <= allow * max(1.0, np.max(np.abs(Adr))), (x, xr)
    assert np.max(np.abs(x - xr)) <= 1e-9 * max(1.0, np.max(np.abs(xr))), (x, xr)


def _against_reference(args, T, tol, dps=15):
    alg, theta, ups, inertia, pot, x0, pi0 = args
    x, pi = fast_flow(alg, theta, ups, inertia, pot, x0, pi0, T, tol=tol)
    xr, pir = reference_flow(alg, theta, ups, inertia, pot, x0, pi0, T, dps=dps)
    _compare(args, x, pi, np.asarray(xr, float), np.asarray(pir, float), tol)


CASES = [("se(3)", True), ("so(4)", False), ("Bianchi III + cocycle", False)]


@needs_numba
@pytest.mark.parametrize("name, grav", CASES + [("su(3)", False), ("aff(1)", True)])
def test_default_full_state_method(name, grav):
    """Off su(2) with Upsilon != 0 the default full-state method is the compiled rational Taylor flow."""
    alg, theta, ups, inertia, pot, _, _ = _model(name, grav=grav)
    model = cached_model(alg, theta, ups, inertia, pot)
    assert fr.applies(model)
    assert choose(model, full=True).name == "taylor-rational"


@needs_numba
@pytest.mark.parametrize("name, grav", CASES)
def test_against_reference(name, grav):
    """T = 0.3 at tol 1e-11 against the mpmath reference at 15 digits: pi, Ad(g) and x."""
    _against_reference(_model(name, seed=1, grav=grav), 0.3, 1e-11)


@needs_numba
def test_su3_against_gauss6():
    """su(3) (complex 3 x 3 representation, Theta and Upsilon != 0): T = 0.5 at tol 1e-11 against the
    numpy Gauss6 flow at its own tolerance 1e-11 (a second route: its own field and re-based chart)."""
    args = _model("su(3)", seed=2)
    alg, theta, ups, inertia, pot, x0, pi0 = args
    x, pi = fast_flow(alg, theta, ups, inertia, pot, x0, pi0, 0.5, tol=1e-11)
    xg, pig = fast_flow(
        alg, theta, ups, inertia, pot, x0, pi0, 0.5, tol=1e-11, method_name="gauss6"
    )
    _compare(args, x, pi, xg, pig, 1e-11, tol_ref=K * 1e-11)


@pytest.mark.slow
@needs_numba
@pytest.mark.parametrize(
    "name, grav, T", [("su(3)", False, 0.5), ("su(3)", True, 0.5), ("sl(3,R)", False, 0.2)]
)
def test_against_reference_dim8_slow(name, grav, T):
    """Dimension 8 against the mpmath reference (sl(3,R) over a shorter time: the reference's own
    time budget)."""
    _against_reference(_model(name, seed=3, grav=grav), T, 1e-11)


@needs_numba
def test_generated_kernel_against_reference():
    """A batch with ``N |t|`` above :data:`GENERATED_MIN_WORK` runs the kernel generated for the
    structure (Bianchi III with a cocycle, n = 3): its first row against the reference, every row
    against its own single call (the kernel compiled for every structure) within the tolerance."""
    args = _model("Bianchi III + cocycle", seed=4)
    alg, theta, ups, inertia, pot, x0, pi0 = args
    T = 0.25
    N = int(np.ceil(fr.GENERATED_MIN_WORK / T))
    rng = np.random.default_rng(9)
    X0 = np.vstack([x0, x0 + 0.05 * rng.standard_normal((N - 1, 3))])
    P0 = np.vstack([pi0, pi0 + 0.05 * rng.standard_normal((N - 1, 3))])
    X, P = fast_flow(alg, theta, ups, inertia, pot, X0, P0, T, tol=1e-11)
    xr, pir = reference_flow(alg, theta, ups, inertia, pot, x0, pi0, T, dps=15)
    _compare(args, X[0], P[0], np.asarray(xr, float), np.asarray(pir, float), 1e-11)
    for j in (1, N - 1):
        xs, ps = fast_flow(alg, theta, ups, inertia, pot, X0[j], P0[j], T, tol=1e-11)
        _compare(args, X[j], P[j], xs, ps, 1e-11, tol_ref=K * 1e-11)


@needs_numba
def test_large_structures_never_compile_the_generated_kernel():
    """The generated kernel only for small structures (its compilation grows faster than its source:
    su(3), 140 products, 18 s), from ``N |t| >= GENERATED_MIN_WORK``; the rule reads the structure
    and the call only."""
    big = fr.rational_full_state(cached_model(*_model("su(3)", seed=5)[:5]), _AbelianPart)
    small = fr.rational_full_state(
        cached_model(*_model("Bianchi III + cocycle", seed=5)[:5]), _AbelianPart
    )
    assert big.fs.n_products > fr.GENERATED_MAX_PRODUCTS >= small.fs.n_products
    work = fr.GENERATED_MIN_WORK
    assert not fr.use_generated(big, 10**6, 10.0)
    assert fr.use_generated(small, int(work), 1.0) and fr.use_generated(small, 1, -work)
    assert not fr.use_generated(small, 1, work / 2)


def _aff1(u, pi0):
    """aff(1) (``[e0, e1] = e1``), ``I = 1``, ``Theta = 0``, ``Upsilon = u J``: ``S = pi_1 J`` and
    ``Phi = (1 - u pi_1) 1``, so ``Delta = (1 - u pi_1)^2`` (docs/conventions.md: 2-dimensional
    algebras, where ``cond(Phi) = 1`` however small ``Delta`` is)."""
    alg = catalogue("aff(1)")
    J = np.array([[0.0, 1.0], [-1.0, 0.0]])
    return alg, np.zeros((2, 2)), u * J, np.eye(2), None, np.zeros(2), np.asarray(pi0, float)


def _crossing_time(u, pi0):
    """The time ``Delta`` reaches 0, in closed form. With ``c = 1 - u pi_1``: ``pidot = -(1/c) S pi``,
    i.e. in the time ``tau`` (``dt = c dtau``) ``pi_0' = -pi_1^2``, ``pi_1' = pi_0 pi_1``; in polar form
    ``pi = R (cos phi, sin phi)``: ``phi' = R sin phi``, so ``tau = ln(tan(phi/2) / tan(phi_0/2)) / R``
    and ``t = int c dtau = tau(phi) - u (phi - phi_0)``, reached at ``sin phi* = 1 / (u R)``."""
    R = float(np.hypot(*pi0))
    p0 = float(np.arctan2(pi0[1], pi0[0]))
    ps = float(np.arcsin(1.0 / (u * R)))
    return np.log(np.tan(ps / 2) / np.tan(p0 / 2)) / R - u * (ps - p0)


@needs_numba
def test_refuses_trajectory_reaching_the_degenerate_set():
    """aff(1) with ``u R > 1``: ``Delta`` reaches 0 at ``t*`` (closed form); the flow to ``t > t*``
    raises DegeneratePointError naming the trajectory and a time within 1e-6 of ``t*`` (the kernel
    stops a few collapsing steps before ``t*``: ``t* - t ~ c^2``, ``c ~ Delta^(1/2)`` at most the
    refusal's ``1e-6``; the integration error of the crossing time is below ``tol / |dDelta/dt|``)."""
    u, pi0 = 0.8, [1.5, 0.5]
    tstar = _crossing_time(u, pi0)
    assert 0.1 < tstar < 0.5
    args = _aff1(u, pi0)
    with pytest.raises(DegeneratePointError, match=r"trajectories \[0\]") as err:
        fast_flow(*args, 2 * tstar, tol=1e-10)
    got = float(re.search(r"t = \[([-+0-9.e]+)", str(err.value)).group(1))
    assert abs(got - tstar) <= 1e-6, (got, tstar)
    x, pi = fast_flow(*args, 0.9 * tstar, tol=1e-10)  # before t*: a flow
    assert 1 - u * pi[1] > 0


@needs_numba
def test_refuses_start_next_to_the_degenerate_set():
    """A batch whose second row starts at ``Delta = (1e-14)^2``: that row is refused by name at
    ``t = 0`` (the sensitivity ``||Phi^-1|| (1 + ||S|| ||U||) ~ 1e14`` exceeds COND_MAX = 1e12 where
    ``cond(Phi) = 1``); no value is returned for the batch."""
    u = 0.8
    alg, theta, ups, inertia, pot, _, _ = _aff1(u, [0.0, 0.0])
    model = cached_model(alg, theta, ups, inertia, pot)
    pi0 = np.array([[0.3, 0.2], [0.3, (1 - 1e-14) / u]]).T
    with pytest.raises(DegeneratePointError, match=r"trajectories \[1\].*t = \[0\.0\]"):
        fr.rational_full_state_flow(model, np.zeros((2, 2)), pi0, 0.5, 1e-10, abelian=_AbelianPart)


def test_applies_refuses_other_models():
    """Upsilon = 0 or su(2) is not this flow's: a clear error names the condition."""
    alg = catalogue("se(3)")
    z = np.zeros((6, 6))
    model = cached_model(alg, z, z, np.eye(6), None)
    assert not fr.applies(model)
    with pytest.raises(ValueError, match="Upsilon = 0: True"):
        fr.rational_full_state_flow(model, np.zeros((6, 1)), np.ones((6, 1)), 1.0, 1e-10)


# ---- the one-trajectory runners of the protocol call (issue 25, Upsilon != 0)
#
# Independent route: the general route of the same call (refimpl._full_state_rational.
# rational_full_state_flow, refimpl._flow_compiled.compiled_taylor_flow: the Python control from its
# start). The runners claim the same computation (the same kernel runs, estimate and logarithm), so
# the answers agree bit for bit; no error model is involved.

RUNNER_CASES = [
    ("se(2)", False, 3.0),
    ("Bianchi III + cocycle", False, -2.0),
    ("se(3)", True, 1.0),
    ("su(2)", False, -10.0),
]  # one su(2) structure: each compiles its own rational kernel (about 10 s of CPU from a cold cache)


def _general(model, x0, pi0, T, tol):
    X, P = x0.reshape(-1, 1).copy(), pi0.reshape(-1, 1).copy()
    if model.su2:
        from tstarg.refimpl._flow_compiled import compiled_taylor_flow

        out = compiled_taylor_flow(model, X, P, T, tol)
    else:
        out = fr.rational_full_state_flow(model, X, P, T, tol, abelian=_AbelianPart)
    return out["x"][:, 0], out["pi"][:, 0]


@needs_numba
@pytest.mark.parametrize("name, grav, T", RUNNER_CASES)
@pytest.mark.parametrize("tol, force", [(1e-10, False), (1e-12, False), (1e-10, True)])
def test_runner_is_the_general_route(name, grav, T, tol, force, monkeypatch):
    """The runner of ``_flow_one`` (routes 2 and 3 with ``Upsilon != 0``) returns the general route's
    answer bit for bit where its first pair passes, and where it does not (``force``: the first
    pair's estimate made infinite, in the runner and in the general route's control alike, so both
    go on from that pair through the control's loop); fresh arrays, the caller's never written."""
    from tstarg.refimpl import _flow_compiled, _full_state
    from tstarg.refimpl.flows import _fast

    args = _model(name, seed=7, grav=grav)
    model = cached_model(*args[:5])
    x0, pi0 = np.array(args[5]), np.array(args[6])
    keep = (x0.copy(), pi0.copy())
    calls = []
    mod = _flow_compiled if model.su2 else _full_state
    go_on = mod._go_on
    monkeypatch.setattr(mod, "_go_on", lambda *a, **k: calls.append(1) or go_on(*a, **k))
    if force:
        for m in (_flow_compiled, fr):
            monkeypatch.setattr(m, "first_estimate", lambda *a: np.inf)
    run = _fast._one_runner(model, tol)
    x, pi = run(x0, pi0, T)
    assert len(calls) == (1 if force else 0), calls  # the control entered only from a failed pair
    x2, pi2 = run(x0, pi0, T)  # the second call runs on the entry points and the pooled arrays
    assert np.array_equal(x0, keep[0]) and np.array_equal(pi0, keep[1])
    xg, pig = _general(model, x0, pi0, T, tol)
    for a, b in ((x, xg), (pi, pig), (x2, xg), (pi2, pig)):
        assert a.shape == (model.n,) and np.array_equal(a, b), (a, b)
    assert not np.shares_memory(x, x2) and not np.shares_memory(pi, pi2)


@needs_numba
@pytest.mark.parametrize("name", ["su(2)", "se(2)", "so(4)", "aff(1)", "Bianchi III + cocycle"])
def test_compiled_start_check_is_the_numpy_rule(name):
    """The runners' compiled start check flags the points that the flows' numpy check
    (refimpl._fast_kernels.start_degenerate: the su(2) closed form, else the generic conditioning)
    flags: random points, points on ``det(1 + Upsilon S) = 0`` (a real root ``s`` of ``p = s v``) and
    next to it, every point outside a factor-4 band around the rule's threshold (where rounding of
    the two inversions may decide either way)."""
    from tstarg.refimpl import _fast_kernels as fk

    rng = np.random.default_rng(11)
    for k in range(6):
        alg, theta, ups = _model(name, seed=k, ups=0.3)[:3]
        model = cached_model(alg, theta, ups, np.eye(alg.f.shape[0]), None)
        f, n = np.asarray(model.f, float), model.n
        check = fr.start_check(model)
        points = [rng.standard_normal(n) * s for s in (0.1, 1.0, 10.0)]
        v = rng.standard_normal(n)
        US = ups @ np.einsum("m,mab->ab", v, f)
        for lam in np.linalg.eigvals(US):
            if abs(lam.imag) < 1e-12 and abs(lam.real) > 1e-6:  # 1 + s lam = 0: det = 0
                s = -1.0 / lam.real
                points += [s * v, s * (1 + 1e-15) * v, s * (1 + 1e-9) * v]
        for p in points:
            p = np.ascontiguousarray(p, dtype=float)
            S = np.einsum("m,mab->ab", p, f) - model.theta
            Psi = np.eye(n) + ups @ S
            with np.errstate(all="ignore"):  # the rule's measure, max(cond, sens), by the SVD
                sv = np.linalg.svd(Psi, compute_uv=False)
                fi = np.sqrt(np.sum(sv**-2.0))
                eff = max(
                    np.linalg.norm(Psi) * fi / n,
                    fi * (1 + np.linalg.norm(S) * np.linalg.norm(ups)) / np.sqrt(n),
                )
            band = 0.25 <= eff * n * fk.C_P * fk.EPS <= 4.0
            if band:
                continue
            want = bool(fk.start_degenerate(f, model.theta, model.upsilon, p[None, :])[0])
            assert check(p) == want, (name, k, p, want)


@needs_numba
def test_runner_refuses_start_on_the_degenerate_set():
    """One trajectory (the runners' route) starting where ``Delta = 0`` exactly is refused with the
    start check's message, on su(2) (``pi.tau = 1``, ``C1 = 0``) and on aff(1) (``Upsilon = u J``,
    ``pi_1 = 1/u``: ``Phi = 0``); a start off the set flows."""
    F = np.asarray(catalogue("su(2)").f, float)
    tau = np.array([0.0, 0.0, 0.5])
    U = np.einsum("l,lmn->mn", tau, F)
    z = np.zeros((3, 3))
    with pytest.raises(ValueError, match=r"initial point\(s\) \[0\] lie on the degenerate set"):
        fast_flow(F, z, U, np.eye(3), None, np.zeros(3), np.array([0.3, 0.1, 2.0]), 1.0)
    args = _aff1(0.5, [0.3, 2.0])
    with pytest.raises(ValueError, match=r"initial point\(s\) \[0\] lie on the degenerate set"):
        fast_flow(*args, 0.5, tol=1e-10)
    x, pi = fast_flow(*_aff1(0.5, [0.3, 0.2]), 0.5, tol=1e-10)
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(pi))
