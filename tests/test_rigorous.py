"""The rigorous (Arb ball) implementation against the mpmath reference, on every catalogue algebra and regime.

What a ball must satisfy (refimpl/rigorous.py):

* it contains the exact value: checked against the mpmath reference at >= 100 digits, 10 digits more
  than the tightest ball's relative radius (about 1e-60 at 200 bits, less where guard bits were added),
  so the reference's own error is far below the radii and containment is a real test, not a tolerance;
* the reference at dps 50 agrees with the ball to its promise: the distance from the 50-digit value
  to the ball is at most ``10^-50 * cond * scale`` (``cond`` the sensitivity of the point,
  ``||Phi^-1|| (1 + ||S|| ||Upsilon||)``, docs/conventions.md; ``scale = max(1, max|P|)``);
* it is tight: radius <= ``1e-45 * scale`` at 200 bits, and a value moved by twice the radius
  (plus ``1e-62 scale``) lies outside (negative control).
"""

from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest
import sympy
from flint import arb_mat
from hypothesis import given, reject, settings
from hypothesis import strategies as st

from tests._helpers import regime_cases
from tstarg.properties.profiles import ref_examples
from tstarg.properties.strategies import lie_algebras
from tstarg.refimpl import CATALOGUE_NAMES, catalogue, su2, su3
from tstarg.refimpl._arb import to_arb, workprec
from tstarg.refimpl.fast import implementation as fast
from tstarg.refimpl.reference import Reference
from tstarg.refimpl.rigorous import (
    Balls,
    ChartError,
    DegeneratePointError,
    Rigorous,
    UndecidedError,
    distance_to_ball,
    error_bounds,
    implementation,
    judge_poisson,
    judge_vector_field,
    phi1_ball,
)

REGIMES = ("generic", "near_degenerate", "large_momenta", "near_chart_boundary")
EPS = np.finfo(float).eps
R200 = Rigorous(200)


def _point(name: str, regime: str, seed: int = 7):
    """(algebra, theta, upsilon, x, pi, cond) for a regime; theta is a coboundary -xi.f (zeven3)."""
    alg = catalogue(name)
    f = alg.f
    n = f.shape[0]
    rng = np.random.default_rng(seed + 1000 * CATALOGUE_NAMES.index(name))
    xi = 0.3 * rng.normal(size=n)
    theta = -np.einsum("k,kab->ab", xi, f)
    U = 0.3 * rng.normal(size=(n, n))
    U = U - U.T
    x = 0.5 * rng.normal(size=n)
    pi = rng.normal(size=n)
    if regime == "large_momenta":
        pi, U = 1e3 * pi, 1e-3 * U
    elif regime == "near_degenerate":
        S = np.einsum("m,mab->ab", pi, f) - theta
        lam = np.linalg.eigvals(S @ U)
        real = [v.real for v in lam if abs(v.imag) <= 1e-9 * abs(v) and abs(v) > 1e-6]
        # det(1 + s S U) = prod(1 + s lam): s = -1/lam is degenerate; stop 1e-9 short of it
        if real:
            U = U * (-1.0 / max(real, key=abs)) * (1 - 1e-9)
    elif regime == "near_chart_boundary":
        ad = np.einsum("a,mab->mb", x, f)
        im = np.max(np.abs(np.linalg.eigvals(ad).imag))
        x = x * (2 * np.pi * (1 - 1e-3) / im if im > 1e-9 else 6.0 / np.linalg.norm(x))
    S = np.einsum("m,mab->ab", pi, f) - theta
    Phi = np.eye(n) + S @ U
    cond = np.linalg.norm(np.linalg.inv(Phi), 2) * (1 + np.linalg.norm(S, 2) * np.linalg.norm(U, 2))
    return alg, theta, U, x, pi, max(1.0, cond)


def _arr(m) -> np.ndarray:
    return np.array([[m[i, j] for j in range(m.cols)] for i in range(m.rows)], dtype=object)


def _ref_dps(*balls: Balls) -> int:
    """Digits the containment reference needs: 10 more than the tightest ball's relative radius (>= 100)."""
    worst = 100
    for B in balls:
        scale = max(1.0, float(np.max(np.abs(B.mid))))
        rad = B.rad[B.rad > 0]
        if rad.size:
            worst = max(worst, int(np.ceil(-np.log10(rad.min() / scale))) + 10)
    return worst


def _check_ball(B: Balls, refhi: np.ndarray, ref50: np.ndarray, cond: float, what: str) -> None:
    scale = max(1.0, float(np.max(np.abs(B.mid))))
    rad = B.rad
    assert np.all(np.isfinite(B.mid)) and np.all(np.isfinite(rad)), f"{what}: non-finite ball"
    assert rad.max() <= 1e-45 * scale, f"{what}: radius {rad.max():.3g} > 1e-45 * {scale:.3g}"
    inside = B.contains(refhi)
    assert inside.all(), (
        f"{what}: the high-precision reference is outside the ball at {np.argwhere(~inside)[:3].tolist()}"
    )
    dist = distance_to_ball(ref50, B)
    # the 50-digit reference promises 50 digits, up to the conditioning of the point
    assert dist.max() <= 1e-50 * cond * scale, (
        f"{what}: dps-50 reference {dist.max():.3g} away from the ball"
    )
    # negative control: moved by twice the radius plus 1e-62 scale, a value must lie outside
    k = int(np.argmax(np.abs(B.mid)))
    bad = refhi.copy()
    with mpmath.workdps(100):
        bad.flat[k] = bad.flat[k] + mpmath.mpf(2 * rad.flat[k] + 1e-62 * scale)
    assert not B.contains(bad).flat[k], (
        f"{what}: a value 2 radii away is still inside (ball not tight)"
    )
    assert distance_to_ball(bad, B).flat[k] > 0


# the 6- and 8-dimensional algebras outside the generic regime cost 1-2 s each (the reference): slow
P_CASES = [
    pytest.param(
        n, r, marks=[pytest.mark.slow] if catalogue(n).f.shape[0] > 5 and r != "generic" else []
    )
    for n, r in regime_cases(REGIMES)
]


@pytest.mark.parametrize(("name", "regime"), P_CASES)
def test_poisson_tensor_balls_contain_reference(name, regime):
    alg, theta, U, x, pi, cond = _point(name, regime)
    B = R200.poisson_tensor_balls(alg, theta, U, x, pi)
    refhi = _arr(Reference(_ref_dps(B)).poisson_tensor_mp(alg, theta, U, x, pi))
    ref50 = _arr(Reference(50).poisson_tensor_mp(alg, theta, U, x, pi))
    _check_ball(B, refhi, ref50, cond, f"P on {name}, {regime}")


VF_CASES = [
    pytest.param(n, r, marks=[pytest.mark.slow] if catalogue(n).f.shape[0] > 5 else [])
    for n in CATALOGUE_NAMES
    for r in ("generic", "near_chart_boundary")
]


@pytest.mark.parametrize(("name", "regime"), VF_CASES)
def test_vector_field_balls_contain_reference(name, regime):
    alg, theta, U, x, pi, cond = _point(name, regime, seed=11)
    n = alg.f.shape[0]
    rng = np.random.default_rng(5)
    G = rng.normal(size=(n, n))
    inertia = G @ G.T + n * np.eye(n)
    pot = {"kind": "gravity", "L": rng.normal(size=n), "gamma": rng.normal(size=n)}
    xd, pd = R200.hamiltonian_vector_field_balls(alg, theta, U, inertia, pot, x, pi)
    rhi = Reference(_ref_dps(xd, pd)).hamiltonian_vector_field_mp(
        alg, theta, U, inertia, pot, x, pi
    )
    r50 = Reference(50).hamiltonian_vector_field_mp(alg, theta, U, inertia, pot, x, pi)
    for ball, a, b, what in ((xd, rhi[0], r50[0], "xdot"), (pd, rhi[1], r50[1], "pidot")):
        _check_ball(
            ball,
            np.array(list(a), dtype=object),
            np.array(list(b), dtype=object),
            cond,
            f"{what} on {name}, {regime}",
        )


def test_exact_algebraic_inputs_enter_as_balls():
    """su(3)'s sqrt(3)/2 and VII_h's sqrt(3) come from the exact constants: balls of radius ~1e-60, not
    a float's 1e-17; the float64 constants give a different (nearby) model the balls tell apart."""
    alg = su3()
    n = 8
    rng = np.random.default_rng(3)
    x, pi = 0.4 * rng.normal(size=n), rng.normal(size=n)
    Z = np.zeros((n, n))
    exact = R200.poisson_tensor_balls(alg, Z, Z, x, pi)
    floaty = R200.poisson_tensor_balls(alg.f, Z, Z, x, pi)
    assert exact.max_rad() < 1e-55
    ref = _arr(Reference(100).poisson_tensor_mp(alg, Z, Z, x, pi))
    assert exact.contains(ref).all()
    # the float64 sqrt(3)/2 is off by ~1e-17: that model's tensor differs from the exact one by far more than the radii
    assert not floaty.contains(ref).all()
    vii = catalogue("Bianchi VII_h(h=3)")
    B = R200.poisson_tensor_balls(
        vii, np.zeros((3, 3)), np.zeros((3, 3)), [0.3, -0.2, 0.5], [1, 2, 3]
    )
    assert B.max_rad() < 1e-55
    assert B.contains(
        _arr(
            Reference(100).poisson_tensor_mp(
                vii, np.zeros((3, 3)), np.zeros((3, 3)), [0.3, -0.2, 0.5], [1, 2, 3]
            )
        )
    ).all()


def test_rational_and_sympy_inputs_match_exact_su2_closed_form():
    """su(2), Theta = 0, Upsilon = tau.eps, x = 0 (so L = 1): the body tensor's pi-pi block is
    ``-S Psi^-1``; with exact inputs, its exact value from sympy lies inside the balls."""
    tau = [Fraction(1, 3), "1/7", sympy.Rational(-2, 5)]
    pi = [Fraction(2, 3), sympy.sqrt(2), "0.25"]
    Ue = sympy.Matrix(
        3,
        3,
        lambda m, k: sum(sympy.LeviCivita(l, m, k) * sympy.sympify(str(tau[l])) for l in range(3)),
    )
    pe = [sympy.Rational(2, 3), sympy.sqrt(2), sympy.Rational(1, 4)]
    Se = sympy.Matrix(3, 3, lambda a, b: sum(sympy.LeviCivita(m, a, b) * pe[m] for m in range(3)))
    Psi = sympy.eye(3) + Ue * Se
    want = -(Se * Psi.inv())
    U = np.array([[Ue[i, j] for j in range(3)] for i in range(3)], dtype=object)
    B = R200.poisson_tensor_balls(su2(), np.zeros((3, 3), dtype=int), U, [0, 0, 0], pi)
    block = B[3:, 3:]
    assert block.contains(
        np.array([[want[i, j] for j in range(3)] for i in range(3)], dtype=object)
    ).all()
    assert block.max_rad() < 1e-55


def test_phi1_series_tail_bound_contains_van_loan_exponential():
    """phi1(M) from the series with its tail bound contains the block exponential's (Arb expm, another
    rigorous route: Van Loan's ``expm([[M, 1], [0, 0]])``); for a nilpotent M the exact finite sum."""
    rng = np.random.default_rng(2)
    with workprec(256):
        for scale in (0.1, 3.0, 12.0):
            Mf = scale * rng.normal(size=(4, 4))
            M = arb_mat(Mf.tolist())
            A = phi1_ball(M, 256)
            big = arb_mat(8, 8)
            for i in range(4):
                for j in range(4):
                    big[i, j] = M[i, j]
                big[i, 4 + i] = 1
            E = big.exp()
            for i in range(4):
                for j in range(4):
                    assert A[i, j].overlaps(E[i, 4 + j]), (scale, i, j)
                    assert A[i, j].rad() < 1e-40 * max(1, abs(float(E[i, 4 + j].mid())))
        N = arb_mat([[0, 2, 5], [0, 0, 3], [0, 0, 0]])  # N^3 = 0: phi1(N) = 1 + N/2 + N^2/6 exactly
        exact = arb_mat([[1, 1, 2.5 + 1], [0, 1, 1.5], [0, 0, 1]])
        A = phi1_ball(N, 256)
        for i in range(3):
            for j in range(3):
                assert A[i, j].contains(exact[i, j]) and A[i, j].rad() < 1e-70


def test_degenerate_point_is_decided():
    """su(2): Delta = C1^2, C1 = 1 - pi.tau (Theta = 0). Exactly degenerate -> DegeneratePointError
    (a ValueError), both with exact binary floats and with 1/3 (decided exactly at the cap);
    Delta = 2^-600 (undecidable at 200 bits) is decided by the precision ladder."""
    eps3 = su2().f
    Z = np.zeros((3, 3))

    def U(tau):
        return np.array(
            [[sum(eps3[l, m, k] * tau[l] for l in range(3)) for k in range(3)] for m in range(3)],
            dtype=object,
        )

    with pytest.raises(DegeneratePointError):
        R200.poisson_tensor_balls(
            su2(), Z, U([2.0, 0, 0]).astype(float), [0.1, 0.2, 0.3], [0.5, 0.0, 0.0]
        )
    with pytest.raises(ValueError, match="degenerate"):
        Rigorous(64, 256).poisson_tensor_balls(
            su2(), Z, U([3, 0, 0]), [0.1, 0.2, 0.3], [Fraction(1, 3), 0, 0]
        )
    tiny = Fraction(1) - Fraction(1, 2**300)
    q = R200.phi_psi_delta_balls(su2(), Z, U([1, 0, 0]), [tiny, 0, 0])
    delta = q["Delta"].balls.item()
    assert not delta.contains(0)
    assert q["Delta"].contains(np.array(sympy.Rational(1, 2**600), dtype=object)).all()
    assert q["Delta"].prec_bits > 2 * 200  # decided only after the ladder doubled the precision
    with pytest.raises(UndecidedError):
        Rigorous(200, 200).phi_psi_delta_balls(su2(), Z, U([1, 0, 0]), [tiny, 0, 0])
    # the fixed point of the float check: Upsilon = 0 is never degenerate, Delta = 1 exactly
    q0 = R200.phi_psi_delta_balls(su2(), Z, Z, [5.0, 1.0, 2.0])
    assert q0["Delta"].balls.item().is_exact() and q0["Delta"].mid.item() == 1.0


def test_chart_boundary_is_refused_not_wrong():
    """At |x| = 2 pi exactly (sympy pi) phi1(-ad_x) is singular: refused by the shared chart rule (the fast
    path's, float64 accuracy) before any ball work, as within float64 rounding of the edge."""
    Z = np.zeros((3, 3))
    for x0 in (2 * sympy.pi, 2 * sympy.pi - sympy.Rational(1, 10**40)):
        with pytest.raises(ChartError, match="chart"):
            Rigorous(64, 256).poisson_tensor_balls(
                su2(), Z, Z, np.array([x0, 0, 0], dtype=object), [1, 2, 3]
            )


def test_protocol_midpoints_are_the_rounded_reference():
    """Protocol methods return float64 midpoints whose radii are below 2^-60 of the scale: each entry is
    within one ulp of the correctly rounded reference (error model: 1 ulp of the midpoint + 1 of the
    reference's rounding, i.e. 2 eps max|P|)."""
    alg, theta, U, x, pi, _ = _point("su(3)", "generic")
    P = implementation.poisson_tensor(alg, theta, U, x, pi)
    ref = np.array(_arr(Reference(50).poisson_tensor_mp(alg, theta, U, x, pi)), dtype=float)
    assert P.dtype == float and P.shape == (16, 16)
    assert np.max(np.abs(P - ref)) <= 2 * EPS * np.max(np.abs(ref))
    inertia, pot = (
        np.diag([1.0, 2, 3]),
        {"kind": "gravity", "L": [0, 0, 1.0], "gamma": [0, 0, -1.0]},
    )
    a2, th2, U2, x2, pi2, _ = _point("su(2)", "generic")
    xd, pd = implementation.hamiltonian_vector_field(a2, th2, U2, inertia, pot, x2, pi2)
    rx, rp = Reference(50).hamiltonian_vector_field(a2, th2, U2, inertia, pot, x2, pi2)
    assert np.max(np.abs(xd - rx)) <= 2 * EPS * np.max(np.abs(rx))
    assert np.max(np.abs(pd - rp)) <= 2 * EPS * np.max(np.abs(rp))


def test_judge_api_and_error_bounds():
    """judge_poisson: (mid, rad); error_bounds of the float64 fast implementation bracket its true error
    (lo <= hi), and a float64 implementation is within its error model c eps cond scale (c = 64 n)."""
    alg, theta, U, x, pi, cond = _point("su(2)", "generic")
    mid, rad = judge_poisson(alg.f, theta, U, x, pi)
    B = R200.poisson_tensor_balls(alg.f, theta, U, x, pi)
    assert np.array_equal(mid, B.mid) and np.all(rad <= 1e-55)
    Pf = fast.poisson_tensor(alg.f, theta, U, x, pi)
    lo, hi = error_bounds(Pf, B)
    assert np.all(lo <= hi) and np.all(
        hi - lo <= 2 * rad + 4 * EPS * hi
    )  # outward rounding: an ulp each
    assert hi.max() <= 64 * 3 * EPS * cond * max(1, np.abs(mid).max())
    (xm, xr), (pm, pr) = judge_vector_field(alg.f, theta, U, np.eye(3), None, x, pi)
    assert xm.shape == pm.shape == (3,) and xr.max() < 1e-50 and pr.max() < 1e-50


def test_bad_input_and_no_mutation():
    alg, theta, U, x, pi, _ = _point("su(2)", "generic")
    copies = [a.copy() for a in (theta, U, x, pi)]
    R200.poisson_tensor_balls(alg, theta, U, x, pi)
    for a, c in zip((theta, U, x, pi), copies):
        assert np.array_equal(a, c)
    with pytest.raises(ValueError, match="x must have shape"):
        R200.poisson_tensor_balls(alg, theta, U, x[:2], pi)
    with pytest.raises(ValueError, match="NaN"):
        R200.poisson_tensor_balls(alg, theta, U, x, np.array([np.nan, 0, 0]))
    with pytest.raises(ValueError, match="antisymmetric"):
        R200.poisson_tensor_balls(alg, theta, U + np.eye(3), x, pi)
    with pytest.raises(ValueError, match="prec_bits"):
        Rigorous(10)
    with pytest.raises(ValueError, match="pi"):
        R200.poisson_tensor_balls(alg, theta, U, x, ["a", 0, 0])


@settings(max_examples=ref_examples(0.6))
@given(alg=lie_algebras(max_dim=4), data=st.data())
def test_random_algebras_vector_field_is_poisson_tensor_times_gradient(alg, data):
    """vier10/vier11 against vier9: with V = 0, ``zdot = P grad H`` and ``grad H = (0, I^-1 pi)``, so
    ``xdot = P_x,pi dK`` and ``pidot = P_pi,pi dK``: the balls of the two formulas overlap, and the
    60-digit reference lies inside both (128 bits: radii about 1e-35, far above the reference's error)."""
    n = alg.f.shape[0]
    num = st.floats(-1.0, 1.0, allow_nan=False, width=32)
    x = np.array(data.draw(st.lists(num, min_size=n, max_size=n)), dtype=float) * 0.8
    pi = np.array(data.draw(st.lists(num, min_size=n, max_size=n)), dtype=float) * 2.0
    u = (
        np.array(data.draw(st.lists(num, min_size=n * n, max_size=n * n)), dtype=float).reshape(
            n, n
        )
        * 0.3
    )
    U = u - u.T
    inertia = np.diag(
        1.0 + np.abs(np.array(data.draw(st.lists(num, min_size=n, max_size=n)), dtype=float))
    )
    Z = np.zeros((n, n))
    R = Rigorous(128)
    try:
        P = R.poisson_tensor_balls(alg, Z, U, x, pi)
    except (DegeneratePointError, UndecidedError):
        reject()
    xd, pd = R.hamiltonian_vector_field_balls(alg, Z, U, inertia, None, x, pi)
    with workprec(160):
        dK = [
            to_arb(p) / to_arb(inertia[i, i]) for i, p in enumerate(pi.tolist())
        ]  # exact inputs, ball quotient
        for k in range(n):
            vx = sum((P.balls[k, n + j] * dK[j] for j in range(n)), arb_mat(1, 1)[0, 0])
            vp = sum((P.balls[n + k, n + j] * dK[j] for j in range(n)), arb_mat(1, 1)[0, 0])
            assert vx.overlaps(xd.balls[k]) and vp.overlaps(pd.balls[k]), (
                k,
                vx,
                xd.balls[k],
                vp,
                pd.balls[k],
            )
    ref = Reference(60)
    assert P.contains(_arr(ref.poisson_tensor_mp(alg, Z, U, x, pi))).all()
    rx, rp = ref.hamiltonian_vector_field_mp(alg, Z, U, inertia, None, x, pi)
    assert (
        xd.contains(np.array(list(rx), dtype=object)).all()
        and pd.contains(np.array(list(rp), dtype=object)).all()
    )


def test_inputs_enter_exactly():
    """Binary floats of any precision (float64, mpmath, sympy Float) become exact balls; rationals and
    radicals become balls around their exact values; what is not a real number is refused by name."""
    with workprec(200), mpmath.workdps(40):
        for v in (0.1, mpmath.mpf("0.1"), sympy.Float("0.1", 30), -1.5, 7, np.int64(-3)):
            b = to_arb(v)
            assert b.is_exact() and b.contains(to_arb(sympy.Rational(*_ratio(v))))
        third = to_arb(Fraction(1, 3))
        assert not third.is_exact() and third.rad() < 1e-59 and (3 * third).contains(1)
        s3 = to_arb(sympy.sqrt(3) / 2)
        assert (4 * s3 * s3).contains(3) and s3.rad() < 1e-59
    for bad in (sympy.I, sympy.Symbol("y"), "abc", None, True, float("nan")):
        with pytest.raises(ValueError, match="v:"):
            to_arb(bad, "v")


def _ratio(v):
    """The exact rational of a binary float, independently of refimpl: via Python's Fraction."""
    if isinstance(v, mpmath.mpf):
        m, e = v.man_exp
        q = Fraction(int(m)) * Fraction(2) ** int(e) * (-1 if v < 0 else 1)
    elif isinstance(v, sympy.Float):
        q = Fraction(str(sympy.Rational(v)))
    else:
        q = Fraction(float(v)) if not isinstance(v, (int, np.integer)) else Fraction(int(v))
    return q.numerator, q.denominator


def test_judge_over_a_batch_names_the_bad_point():
    """Batched judge: the same balls as point by point; a degenerate point (su(2), pi.tau = 1) is named."""
    alg = su2()
    rng = np.random.default_rng(4)
    X, PI = 0.3 * rng.normal(size=(2, 2, 3)), rng.normal(size=(2, 2, 3))
    tau = np.array([0.5, 0.0, 0.0])
    U = np.einsum("l,lmn->mn", tau, alg.f)
    Z = np.zeros((3, 3))
    mid, rad = judge_poisson(alg, Z, U, X, PI, prec_bits=128)
    assert mid.shape == rad.shape == (2, 2, 6, 6)
    m11, r11 = judge_poisson(alg, Z, U, X[1, 1], PI[1, 1], prec_bits=128)
    assert np.array_equal(mid[1, 1], m11) and np.array_equal(rad[1, 1], r11)
    (xm, _), (pm, pr) = judge_vector_field(alg, Z, U, np.eye(3), None, X, PI, prec_bits=128)
    assert xm.shape == pm.shape == pr.shape == (2, 2, 3)
    PI[0, 1] = [2.0, 0.3, -0.1]  # pi.tau = 1: Delta = 0 exactly
    with pytest.raises(DegeneratePointError, match=r"point \(0, 1\)"):
        judge_poisson(alg, Z, U, X, PI, prec_bits=128)


@pytest.mark.parametrize("name", ["su(2)", "so(4)", "Bianchi VI_h(h=-2)"])
def test_body_frame_tensor_is_minus_w_inverse(name):
    """frame="body": the blocks of -W^-1 (vier9); the reference's first-principles inverse of W (vier3,
    at 100 digits) lies inside; and the holonomic tensor at x = 0 (L = 1) has the same balls' values."""
    alg, theta, U, _, pi, _ = _point(name, "generic", seed=3)
    n = alg.f.shape[0]
    B = R200.poisson_tensor_balls(alg, theta, U, np.zeros(n), pi, frame="body")
    W = Reference(100).poisson_tensor_mp(
        alg, theta, U, np.zeros(n), pi, route="first_principles", frame="body"
    )
    assert B.contains(_arr(W)).all() and B.max_rad() < 1e-55
    H = R200.poisson_tensor_balls(alg, theta, U, np.zeros(n), pi)
    assert all(h.overlaps(b) for h, b in zip(H.balls.flat, B.balls.flat))
