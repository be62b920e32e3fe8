"""The rigorous implementation is safe to trust (issue 30): it refuses what the reference refuses, and every
ball it returns contains a higher-precision value computed by an independent route.

* Refusals (the reproducers of issue 30): the chart edge (``x = [2 pi, 0, 0]`` in float64 and
  ``nextafter(2 pi, 0)`` on su(2)), the work budget ``||ad_x||_1 <= 400`` (sl(2,R) at ``1e4 * dir``,
  h(3) at ``(1e6, 1e6, 0)``, su(2) at ``x = (0, 0, 1e17)``, which used to abort inside FLINT), the
  magnitude boundary 1e300 and the precision cap (``Rigorous(10**9)``), each within a second.
* Containment, randomized: catalogue algebras, a Theta coboundary, a random Upsilon, points with
  magnitudes drawn over 10^-300 .. 10^300 for pi, Theta and Upsilon, x anywhere from 0 to past the chart
  edge. Either the rigorous implementation refuses (then the point is at or past the chart edge, over a
  budget, or degenerate), or every ball of the Poisson tensor and of the vector field contains the value of
  an independent mpmath route (:func:`_independent`, below) at twice the digits of the balls (120 digits
  against 200 bits); and a value moved by twice the radius lies outside (the balls are tight). When the
  mpmath reference refuses a point, the rigorous one must refuse it too, except that the reference's
  degeneracy test (``|Delta| <= 16 n eps ||Phi||^n``) also refuses non-degenerate points of huge
  ``||Phi||`` (issue 30: "true Delta ~2.4e198"): there the rigorous ``Delta`` ball provably excludes 0
  and the independent route decides.

The independent route computes the frames by the block exponential (van Loan: ``phi1(M)`` is a block of
``expm([[M, 1], [0, 0]])``, mpmath's Pade/Taylor ``expm``, not the rigorous series) and the rest from the
CONVENTIONS formulas (vier9-vier11, twee15/16), at a working precision that covers the cancellation of the
inputs' magnitudes.
"""

from __future__ import annotations

import math
import signal
import time

import mpmath
import numpy as np
import pytest
import sympy
from flint import arb

from tstarg.refimpl import CATALOGUE_NAMES, catalogue, su2
from tstarg.refimpl._errors import ChartError, DegeneratePointError
from tstarg.refimpl.reference import Reference
from tstarg.refimpl.rigorous import MAX_PREC_BITS, Rigorous, distance_to_ball

Z = np.zeros((3, 3))


def sl2r():
    return catalogue("sl(2,R)")


def h3():
    return catalogue("h(3)")


P3 = np.array([0.3, 0.2, 0.5])


def _up2(tau: float) -> np.ndarray:
    U = np.zeros((3, 3))
    U[0, 1], U[1, 0] = tau, -tau
    return U


@pytest.fixture
def within_a_second():
    """Every refusal comes within a second (a hang fails the test instead of stalling the run)."""

    def boom(*_):
        raise TimeoutError("no answer within 5 s")

    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(5)
    t0 = time.process_time()
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)
    assert time.process_time() - t0 < 1.0


# ------------------------------------------------------------------ the reproducers of issue 30
@pytest.mark.parametrize("x0", [2 * np.pi, np.nextafter(2 * np.pi, 0)])
def test_chart_edge_is_refused_as_the_reference_does(x0, within_a_second):
    x = np.array([x0, 0.0, 0.0])
    with pytest.raises(ChartError, match="outside the chart"):
        Reference(60).poisson_tensor(su2(), Z, _up2(0.7), x, P3)
    G = Rigorous(200)
    with pytest.raises(ChartError, match="outside the chart"):
        G.poisson_tensor(su2(), Z, _up2(0.7), x, P3)
    with pytest.raises(ChartError, match="outside the chart"):
        G.hamiltonian_vector_field(su2(), Z, _up2(0.7), np.eye(3), None, x, P3)


@pytest.mark.parametrize(
    ("alg", "x"),
    [
        (sl2r, 1e4 * np.array([1.0, 0.5, 0.2]) / np.linalg.norm([1.0, 0.5, 0.2])),
        (sl2r, np.array([1e6, 1e6, 0.0])),
        (h3, np.array([1e6, 1e6, 0.0])),
        (h3, 1e4 * np.array([1.0, 0.5, 0.2]) / np.linalg.norm([1.0, 0.5, 0.2])),
    ],
)
def test_work_budget_is_refused_as_the_reference_does(alg, x, within_a_second):
    with pytest.raises(ValueError, match="work budget"):
        Reference(60).poisson_tensor(alg(), Z, Z, x, P3)
    with pytest.raises(ValueError, match="work budget"):
        Rigorous(200).poisson_tensor(alg(), Z, Z, x, P3)


def test_huge_x_on_su2_is_refused_not_aborted(within_a_second):
    """x = (0, 0, 1e17) used to ask FLINT for 8e16 bytes of guard bits and abort the process."""
    with pytest.raises(ChartError):
        Rigorous(200).poisson_tensor(su2(), Z, _up2(0.7), np.array([0.0, 0.0, 1e17]), P3)


def test_precision_cap(within_a_second):
    assert MAX_PREC_BITS == math.ceil(5000 * math.log2(10))
    for bad in (10**9, MAX_PREC_BITS + 1, True, 52):
        with pytest.raises(ValueError, match="prec_bits"):
            Rigorous(bad)
    with pytest.raises(ValueError, match="max_prec_bits"):
        Rigorous(200, 10**9)
    assert Rigorous(MAX_PREC_BITS).max_prec_bits == MAX_PREC_BITS


@pytest.mark.parametrize(
    "where", ["pi", "x", "theta", "upsilon", "inertia", "potential", "exact pi"]
)
def test_magnitudes_beyond_1e300_are_refused_by_name(where, within_a_second):
    G = Rigorous(200)
    x, pi, U, theta, inertia = np.array([0.1, 0.2, 0.3]), P3.copy(), _up2(0.5), Z.copy(), np.eye(3)
    pot = {"kind": "gravity", "L": np.array([0, 0, 1.0]), "gamma": np.array([0, 0, -1.0])}
    big = 3e300
    if where == "pi":
        pi = pi * 1e301
    elif where == "x":
        x = np.array([0.0, 0.0, big])
    elif where == "theta":
        theta = _up2(big)
    elif where == "upsilon":
        U = _up2(big)
    elif where == "inertia":
        inertia = np.diag([1.0, 1.0, big])
    elif where == "potential":
        pot["gamma"] = np.array([0, 0, -big])
    else:
        from fractions import Fraction

        pi = np.array([Fraction(10**400), 0, 0], dtype=object)
    name = where.split()[-1]
    with pytest.raises(ValueError, match=name):
        G.hamiltonian_vector_field(su2(), theta, U, inertia, pot, x, pi)


def test_vector_field_beyond_the_float64_range_is_refused(within_a_second):
    """pi = 1e300 p: the exact pidot ~ |pi|^2 ~ 1e600 exists, but no float64 answer does (the fast path
    returned infinities): refused, naming the result; at pi = 1e150 p it is answered and finite."""
    G = Rigorous(200)
    x = np.array([0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match=r"pidot\[.*beyond 1e\+300"):
        G.hamiltonian_vector_field(su2(), Z, Z, np.diag([1.0, 2, 3]), None, x, P3 * 1e300)
    xd, pd = G.hamiltonian_vector_field_balls(
        su2(), Z, Z, np.diag([1.0, 2, 3]), None, x, P3 * 1e140
    )
    _, (xr, pr) = _independent(su2(), Z, Z, x, P3 * 1e140, np.diag([1.0, 2, 3]), None, dps=150)
    _assert_contains(pd, pr, 1e-100, "pidot at pi = 1e140 p")
    _assert_contains(xd, xr, 1e-100, "xdot at pi = 1e140 p")


def test_upsilon_1e300_balls_contain_the_truth():
    """Upsilon = 1e300 tau: Delta = det(1 + S Upsilon) ~ 1e600 is far from 0 (the reference's error model
    calls it degenerate); the balls contain the independent route's 400-digit value."""
    U = _up2(1e300)
    x = np.array([0.1, 0.2, 0.3])
    G = Rigorous(200)
    delta = G.phi_psi_delta_balls(su2(), Z, U, P3)["Delta"]
    assert abs(delta.balls.item()) > arb(10) ** 500
    B = G.poisson_tensor_balls(su2(), Z, U, x, P3)
    P, _ = _independent(su2(), Z, U, x, P3, None, None, dps=400)
    _assert_contains(B, P, 1e-300, "P at Upsilon = 1e300")


# ------------------------------------------------------------------ the independent route
def _mp(a) -> mpmath.matrix:
    a = np.asarray(a, dtype=float)
    return mpmath.matrix(a.tolist()) if a.ndim == 2 else mpmath.matrix(a.tolist())


def _num(v, dps: int) -> mpmath.mpf:
    if isinstance(v, sympy.Basic):
        return mpmath.mpf(sympy.N(v, dps + 10)._to_mpmath(mpmath.mp.prec + 32))
    return mpmath.mpf(float(v))


def _independent(f, theta, U, x, pi, inertia, pot, *, dps):
    """``(P, (xdot, pidot))`` in mpmath at ``dps`` digits (module docstring); vf only if inertia given."""
    src = f.f_exact if getattr(f, "is_exact", False) else np.asarray(getattr(f, "f", f))
    n = src.shape[0]
    with mpmath.workdps(dps):
        # exact constants (sqrt(2) of Bianchi VI_h, sqrt(3)/2 of su(3)) at the working precision
        F = [[[_num(src[m, a, b], dps) for b in range(n)] for a in range(n)] for m in range(n)]
        xs, ps = [mpmath.mpf(float(v)) for v in x], [mpmath.mpf(float(v)) for v in pi]
        ad = mpmath.matrix(n, n)
        S = mpmath.matrix(n, n)
        for m in range(n):
            for b in range(n):
                ad[m, b] = mpmath.fsum(xs[a] * F[m][a][b] for a in range(n))
        for a in range(n):
            for b in range(n):
                S[a, b] = mpmath.fsum(ps[m] * F[m][a][b] for m in range(n)) - float(theta[a, b])
        big = mpmath.matrix(2 * n, 2 * n)
        for i in range(n):
            for j in range(n):
                big[i, j] = -ad[i, j]
            big[i, n + i] = 1
        E = mpmath.expm(big)
        A = mpmath.matrix([[E[i, n + j] for j in range(n)] for i in range(n)])
        L = mpmath.inverse(A)
        Um = _mp(U)
        Phi = mpmath.eye(n) + S * Um
        Pi = mpmath.inverse(Phi)
        Psi = Pi.T
        blocks = [[L * (-Um * Pi) * L.T, L * Psi], [-Pi * L.T, -S * Psi]]
        P = np.empty((2 * n, 2 * n), dtype=object)
        for bi in range(2):
            for bj in range(2):
                for i in range(n):
                    for j in range(n):
                        P[bi * n + i, bj * n + j] = blocks[bi][bj][i, j]
        if inertia is None:
            return P, None
        dK = mpmath.lu_solve(_mp(inertia), mpmath.matrix(ps))
        dV = mpmath.matrix(n, 1)
        if pot is not None:
            Ad = mpmath.expm(ad)
            Gam = Ad.T * mpmath.matrix([float(v) for v in pot["gamma"]])
            Lv = [float(v) for v in pot["L"]]
            for b in range(n):
                dV[b] = -mpmath.fsum(
                    Gam[m] * F[m][b][c] * Lv[c] for m in range(n) for c in range(n)
                )
        Om = Psi * (dK - Um * dV)
        pid = Pi * (-dV - S * dK)
        xd = L * Om
        return P, (
            np.array([xd[i] for i in range(n)], dtype=object),
            np.array([pid[i] for i in range(n)], dtype=object),
        )


def _assert_contains(B, ref, tol_rel: float, what: str) -> None:
    """``ref`` (an independent value at twice the balls' digits, its own error below ``tol_rel scale``) lies
    in every ball, and a value moved by twice the radius (plus 1e-80 scale, resolved by the judge's
    +64 bits) does not."""
    scale = max(1.0, float(np.max(np.abs(B.mid))))
    assert np.all(np.isfinite(B.mid)) and np.all(np.isfinite(B.rad)), f"{what}: non-finite ball"
    dist = distance_to_ball(ref, B)
    assert dist.max() <= tol_rel * scale, (
        f"{what}: the independent value is {dist.max():.3g} outside a ball (scale {scale:.3g})"
    )
    k = int(np.argmax(B.rad))
    moved = ref.copy()
    with mpmath.workdps(400):
        moved.flat[k] = moved.flat[k] + mpmath.mpf(
            2 * B.rad.flat[k] + max(4 * tol_rel, 1e-80) * scale
        )
    assert distance_to_ball(moved, B).flat[k] > 0, f"{what}: ball not tight at {k}"


# ------------------------------------------------------------------ randomized containment
def _draw(seed: int):
    """One drawn model and point (module docstring); magnitudes are 10^u with u uniform per draw."""
    rng = np.random.default_rng(seed)
    name = CATALOGUE_NAMES[rng.integers(len(CATALOGUE_NAMES))]
    alg = catalogue(name)
    f = alg.f
    n = f.shape[0]

    def mag():
        r = rng.random()
        return 10.0 ** (rng.uniform(-300, 300) if r < 0.25 else rng.uniform(-3, 3))

    xi = rng.normal(size=n) * mag()
    theta = -np.einsum("k,kab->ab", xi, f) if rng.random() < 0.7 else np.zeros((n, n))
    U = rng.normal(size=(n, n)) * (mag() if rng.random() < 0.8 else 0.0)
    U = U - U.T
    pi = rng.normal(size=n) * mag()
    x = rng.normal(size=n)
    x *= rng.choice([1e-3, 0.5, 2.0, 6.0, 7.0, 50.0, 1e4]) / np.linalg.norm(x)
    inertia = np.diag(rng.uniform(0.5, 3.0, size=n))
    pot = None
    if rng.random() < 0.5:
        pot = {"kind": "gravity", "L": rng.normal(size=n), "gamma": rng.normal(size=n)}
    return name, alg, theta, U, x, pi, inertia, pot


def _magnitude_digits(*arrs) -> int:
    """Extra digits the independent route needs for the cancellation of huge and tiny magnitudes."""
    m = max(float(np.max(np.abs(a), initial=0.0)) for a in arrs)
    return 20 + int(3 * abs(math.log10(max(m, 1e-300))) if m > 0 else 0)


def _one_draw(seed: int) -> str:
    name, alg, theta, U, x, pi, inertia, pot = _draw(seed)
    G = Rigorous(200)
    what = f"seed {seed}: {name}, |x| = {np.linalg.norm(x):.3g}, |pi| = {np.max(np.abs(pi)):.3g}"
    try:
        B = G.poisson_tensor_balls(alg, theta, U, x, pi)
        xd, pd = G.hamiltonian_vector_field_balls(alg, theta, U, inertia, pot, x, pi)
        g_err = None
    except ValueError as exc:
        g_err = exc
    try:
        Reference(120).poisson_tensor(alg, theta, U, x, pi)
        r_err = None
    except ValueError as exc:
        r_err = exc
    if g_err is not None:
        # the rigorous refusals: the chart, the budgets, the magnitudes, a degenerate point
        assert isinstance(g_err, (ChartError, DegeneratePointError)) or any(
            k in str(g_err) for k in ("budget", "beyond 1e+300")
        ), f"{what}: unexpected refusal {g_err!r}"
        return "refused"
    if r_err is not None:
        # the reference refused what the rigorous one answered: only its degeneracy test may, at huge ||Phi||
        assert isinstance(r_err, DegeneratePointError), (
            f"{what}: the reference refused ({r_err}) but the rigorous implementation answered"
        )
        dl = G.phi_psi_delta_balls(alg, theta, U, pi)["Delta"].balls.item()
        assert not dl.contains(0)
    nu = float(np.max(np.abs(np.einsum("a,mab->mb", x, alg.f)).sum(axis=0)))
    dps = 120 + _magnitude_digits(theta, U, pi) + int(2 * nu / math.log(10))  # e^||ad_x|| cancels
    P, (xr, pr) = _independent(alg, theta, U, x, pi, inertia, pot, dps=dps)
    tol = 1e-100  # the independent route's own error at >= 120 digits, with 20 digits for conditioning
    _assert_contains(B, P, tol, f"{what}: P")
    _assert_contains(xd, xr, tol, f"{what}: xdot")
    _assert_contains(pd, pr, tol, f"{what}: pidot")
    return "contained" if r_err is None else "contained (reference refused: degenerate)"


@pytest.mark.parametrize("seed", range(12))
def test_random_draws_are_contained_or_refused(seed):
    _one_draw(seed)


@pytest.mark.slow
def test_random_draws_are_contained_or_refused_1000():
    counts: dict = {}
    for seed in range(1000, 2000):
        out = _one_draw(seed)
        counts[out] = counts.get(out, 0) + 1
        if seed % 100 == 99:
            print(f"[{seed - 999}/1000] {counts}", flush=True)
    print("containment run:", counts)
    assert counts.get("contained", 0) >= 300


def test_flow_enclosures_keep_the_boundary(within_a_second):
    """The rigorous flows refuse what the implementations refuse: magnitudes, the precision cap, the flow
    time budget, and a run whose estimated CPU time exceeds ``max_seconds`` (refused with the estimate)."""
    from tstarg.refimpl.rigorous import body_flow_enclosure, full_state_enclosure

    top, grav = (
        np.diag([1.0, 1.0, 0.5]),
        {"kind": "gravity", "L": [0, 0, 1.0], "gamma": [0, 0, -1.0]},
    )
    x0, pi0 = np.array([0.1, 0.2, 0.0]), np.array([0.3, 0.2, 2.0])
    for fn in (body_flow_enclosure, full_state_enclosure):
        with pytest.raises(ValueError, match="pi0"):
            fn(su2(), Z, Z, top, grav, x0, pi0 * 1e301, 1.0)
        with pytest.raises(ValueError, match="prec_bits"):
            fn(su2(), Z, Z, top, grav, x0, pi0, 1.0, prec_bits=10**9)
        with pytest.raises(ValueError, match="flow budget"):
            fn(su2(), Z, Z, top, grav, x0, pi0, 1e5)
        with pytest.raises(ValueError, match="max_seconds"):
            fn(su2(), Z, Z, top, grav, x0, pi0, 1e3, prec_bits=64, max_seconds=0.05)
