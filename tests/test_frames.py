"""Frames of exponential coordinates (twee1, twee3), checked from first principles in a faithful
representation: with g = expm(x^a E_a),
  g E_b g^-1 = Ad[m, b] E_m,     g^-1 dg/dx^i = A[a, i] E_a  (A = L(g^-1, g) = phi1(-ad_x)),
  L(g, e) = A^-1,                K(g) = Ad(g^-1)^T.
The derivative dg/dx^i is the Frechet derivative of expm, taken as the upper-right block of
expm([[X, E_i], [0, X]]) (Van Loan) -- no use of phi1 or of the reference's frame code."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

from tests._helpers import mp_digits
from tstarg.refimpl import CATALOGUE_NAMES, catalogue, frames

REP_ALGEBRAS = [n for n in CATALOGUE_NAMES if catalogue(n).rep_exact is not None]
DPS = 50


def _mp_real(v) -> mpmath.mpf:
    return mpmath.mpf(sympy.Float(sympy.N(v, DPS + 20), DPS + 20)._to_mpmath(mpmath.mp.prec))


def _mp_mat(m: sympy.Matrix) -> mpmath.matrix:
    """Exact sympy entries (possibly complex, e.g. -i sqrt(3)/6) at full working precision."""
    return mpmath.matrix(
        [
            [mpmath.mpc(_mp_real(sympy.re(v)), _mp_real(sympy.im(v))) for v in row]
            for row in m.tolist()
        ]
    )


def _first_principles(alg, x):
    with mpmath.workdps(DPS + 10):
        E = [_mp_mat(m) for m in alg.rep_exact]
        d = E[0].rows
        X = sum((mpmath.mpf(xi) * Ei for xi, Ei in zip(x, E)), mpmath.zeros(d, d))
        g = mpmath.expm(X)
        ginv = mpmath.inverse(g)
        n = alg.dim
        # coordinates of a matrix in the basis E: least squares on the real-stacked entries
        cols = [[Ei[i, j] for i in range(d) for j in range(d)] for Ei in E]

        def coords(M):
            rows = []
            rhs = []
            for k in range(d * d):
                i, j = divmod(k, d)
                rows.append([mpmath.re(c[k]) for c in cols])
                rhs.append(mpmath.re(M[i, j]))
                rows.append([mpmath.im(c[k]) for c in cols])
                rhs.append(mpmath.im(M[i, j]))
            C, r = mpmath.matrix(rows), mpmath.matrix(rhs)
            # normal equations: C has full column rank because the representation is faithful
            sol = mpmath.lu_solve(C.T * C, C.T * r)
            res = mpmath.norm(C * sol - r)
            assert res < mpmath.mpf(10) ** (-(DPS - 5)), (
                "matrix outside the span of the representation"
            )
            return [sol[m] for m in range(n)]

        Ad = np.array([coords(g * E[b] * ginv) for b in range(n)], dtype=object).T
        A_cols = []
        for i in range(n):
            big = mpmath.zeros(2 * d, 2 * d)
            for r in range(d):
                for c in range(d):
                    big[r, c] = X[r, c]
                    big[d + r, d + c] = X[r, c]
                    big[r, d + c] = E[i][r, c]
            dg = mpmath.expm(big)
            D = mpmath.matrix([[dg[r, d + c] for c in range(d)] for r in range(d)])
            A_cols.append(coords(ginv * D))
        A = np.array(A_cols, dtype=object).T
        return A, Ad


xs = st.lists(st.integers(-9, 9), min_size=8, max_size=8).map(
    lambda v: [sympy.Rational(k, 10) for k in v]
)


@pytest.mark.reference
@pytest.mark.parametrize("name", REP_ALGEBRAS)
@settings(max_examples=2)
@given(xv=xs)
def test_frames_match_first_principles(name, xv):
    if catalogue(name).dim > 3 and any(xv):
        # larger algebras: one fixed point below (each example costs ~1 s at 60 digits)
        return
    _check_first_principles(name, xv)


@pytest.mark.reference
@pytest.mark.parametrize("name", [n for n in REP_ALGEBRAS if catalogue(n).dim > 3])
def test_frames_match_first_principles_large(name):
    _check_first_principles(name, [sympy.Rational(k, 10) for k in (3, -5, 2, 1, -4, 6, -2, 5)])


def _check_first_principles(name, xv):
    alg = catalogue(name)
    x = xv[: alg.dim]
    A_fp, Ad_fp = _first_principles(alg, x)
    fr = frames(alg, x, dps=DPS)
    assert mp_digits(fr["A"], A_fp) >= 45, "A = phi1(-ad_x) vs g^-1 dg/dx"
    assert mp_digits(fr["Ad"], Ad_fp) >= 45, "Ad = exp(ad_x) vs g E g^-1"
    with mpmath.workdps(DPS + 10):
        Lm = mpmath.matrix(fr["L"].tolist())
        Am = mpmath.matrix(fr["A"].tolist())
        Kb = mpmath.matrix(fr["K"].tolist())
        Adm = mpmath.matrix(fr["Ad"].tolist())
        eye_err = mpmath.mnorm(Lm * Am - mpmath.eye(alg.dim), 1)
        k_err = mpmath.mnorm(Kb * Adm.T - mpmath.eye(alg.dim), 1)
    assert eye_err < mpmath.mpf(10) ** -45 and k_err < mpmath.mpf(10) ** -45


@pytest.mark.parametrize("name", CATALOGUE_NAMES)
def test_frame_routes_agree(name):
    """Taylor series and Van Loan block exponential give the same phi1(-ad_x) to 45 digits."""
    alg = catalogue(name)
    x = [sympy.Rational(k, 7) for k in (3, -5, 2, 1, -4, 6, -2, 5)][: alg.dim]
    a = frames(alg, x, dps=DPS, route="series")
    b = frames(alg, x, dps=DPS, route="vanloan")
    for key in ("A", "L"):
        assert mp_digits(a[key], b[key]) >= 45, key


@pytest.mark.parametrize("name", CATALOGUE_NAMES)
@pytest.mark.parametrize("rho", [0.1, 0.45, 0.8])
def test_fast_frames_within_error_model(name, rho):
    """float64 frames vs the reference: |L_fast - L_ref| <= 64 n eps ||L|| / (1 - r), r = ||ad_x||_F / 2 pi.

    rho = 0.8 exercises the scaling-and-squaring branch, rho < 0.5 the Bernoulli series."""
    alg = catalogue(name)
    if not alg.f.any():
        # abelian: ad_x = 0, so every frame is exactly the identity
        got = frames(alg.f, np.full(alg.dim, rho))
        assert all(np.array_equal(got[k], np.eye(alg.dim)) for k in ("A", "L", "Ad", "K"))
        return
    x = np.array([0.3, -0.5, 0.2, 0.1, -0.4, 0.6, -0.2, 0.5][: alg.dim])
    x *= rho * 2 * np.pi / np.linalg.norm(np.einsum("a,mab->mb", x, alg.f))
    got = frames(alg.f, x)
    ref = frames(alg.f, x, dps=30)
    n = alg.dim
    for key in ("A", "L", "Ad"):
        r_val = np.array(ref[key], dtype=float)
        scale = max(1.0, float(np.max(np.abs(r_val))))
        # error model: 64 n eps scale / (1 - r) with r = rho (the frame's conditioning)
        tol = 64 * n * np.finfo(float).eps * scale / (1 - rho)
        err = float(np.max(np.abs(got[key] - r_val)))
        assert err <= tol, f"{key}: error {err:.3g} > tolerance {tol:.3g} (ratio {err / tol:.3g})"


def test_su2_frame_matches_rodrigues_closed_form():
    """su(2): L(g,e) = 1 + K/2 + (1/t^2)(1 - (t/2)cot(t/2)) K^2 with K = [x]_x (textbook closed form)."""
    with mpmath.workdps(60):
        x = [mpmath.mpf("0.3"), mpmath.mpf("-1.1"), mpmath.mpf("2.0")]
        t = mpmath.sqrt(sum(v * v for v in x))
        K = mpmath.matrix([[0, -x[2], x[1]], [x[2], 0, -x[0]], [-x[1], x[0], 0]])
        L = mpmath.eye(3) + K / 2 + (1 - (t / 2) * mpmath.cot(t / 2)) / t**2 * K * K
        L_np = np.array(L.tolist(), dtype=object)
    from tstarg.refimpl import su2

    got = frames(su2(), ["0.3", "-1.1", "2.0"], dps=50)["L"]
    assert mp_digits(got, L_np) >= 48
