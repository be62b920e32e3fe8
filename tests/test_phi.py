"""The house's phi1 (refimpl/_phi.py, ``phi1(M) = sum_k M^k/(k+1)! = (e^M - 1)/M``): the float64
route against the mpmath series at 40 digits, the mpmath series against the reference's second
mpmath route (Van Loan's block in mpmath), and both against closed forms (scalar ``expm1(a)/a``, a
nilpotent ``N`` with ``N^3 = 0``, a rotation generator).

The float judge's routes (oracles/float_judge.py: its own ``expm`` and ``phi1`` by Van Loan's block)
stay apart from the house's on purpose and are checked here against the same 40-digit values. Both
``expm`` routes scale scipy's Pade to ``||A||_1 <= 1`` themselves: scipy 1.17.1's ``linalg.expm``
alone errs by 2332 ulp on ``[[4, 0.1], [0.1, 0]]`` (and 2387 in ``phi1([[4]])`` by the block), beyond
the model below; :func:`test_scipy_defect_reproducer` keeps that case.

Error model (float64 against a 40-digit value): every standard route to ``phi1(M)`` errs by at
most ``C n eps expm_route(||M||_1)`` in the max norm, relative to ``max(1, max|phi1(M)|)``, with
``expm_route`` the documented factor ``e^min(||M||_1, 5.37) + s`` (oracles/float_judge.py: the
Taylor series sums terms of total norm ``<= e^||M||``; scaling and squaring adds ``gamma_n`` per
squaring) and ``C = 8`` (the certification's constant). The two mpmath routes at ``dps`` digits
(40, plus the guard digits ``||M||_1 / ln 10 + 5`` the reference adds) agree to ``10^-(dps - 3)``.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

from tstarg.oracles import float_judge
from tstarg.oracles.float_judge import C_CERT, EPS64, expm_route
from tstarg.refimpl._phi import PHI1_TAYLOR, expm, phi1, phi1_mp, phi1_mp_vanloan

DPS = 40
NORMS = (0.0, 0.05, 0.7, 3.0, 9.0)


def _matrices():
    rng = np.random.default_rng(20261125)
    out = []
    for n in (1, 3, 6):
        for norm in NORMS:
            M = rng.standard_normal((n, n))
            if norm:
                M *= norm / np.linalg.norm(M, 1)
            else:
                M[:] = 0.0
            out.append(M)
    return out


MATRICES = _matrices()


def _mp(M):
    return mpmath.matrix(M.tolist())


def _exact(M):
    """phi1(M) to 40 digits by the mpmath series, with the guard digits of the cancellation."""
    extra = int(np.linalg.norm(M, 1) / math.log(10)) + 5
    with mpmath.workdps(DPS + extra):
        E = phi1_mp(_mp(M))
        return np.array([[float(E[i, j]) for j in range(E.cols)] for i in range(E.rows)])


def _tol(M, ref):
    n = M.shape[0]
    return C_CERT * n * EPS64 * expm_route(np.linalg.norm(M, 1)) * max(1.0, np.max(np.abs(ref)))


@pytest.mark.parametrize("k", range(len(MATRICES)))
def test_float_phi1_agrees_with_the_mpmath_series(k):
    M = MATRICES[k]
    ref = _exact(M)
    tol = _tol(M, ref)
    got = phi1(M)
    assert np.all(np.isfinite(got)), f"non-finite at ||M||_1 = {np.linalg.norm(M, 1)}"
    err = float(np.max(np.abs(got - ref)))
    assert err <= tol, (
        f"phi1: error {err:.3g} > {tol:.3g} at n = {M.shape[0]}, ||M||_1 = {np.linalg.norm(M, 1):.3g}"
    )


def _exact_exp(M):
    """exp(M) to 40 digits (mpmath), real or complex."""
    with mpmath.workdps(DPS + int(np.linalg.norm(M, 1) / math.log(10)) + 5):
        E = mpmath.expm(mpmath.matrix(M.tolist()))
        return np.array([[complex(E[i, j]) for j in range(E.cols)] for i in range(E.rows)])


@pytest.mark.parametrize("route", ["house", "judge"])
@pytest.mark.parametrize("k", range(len(MATRICES)))
def test_expm_routes_agree_with_mpmath(k, route):
    """Both float64 ``expm`` routes (refimpl/_phi.py and the float judge's) within the model, relative
    to ``max(1, max|exp(M)|)``, on the module's matrices and on a complex one of the same norm."""
    fn = expm if route == "house" else float_judge.expm
    M = MATRICES[k]
    for A in (M, M + 0.5j * M[::-1].copy()):
        ref = _exact_exp(A)
        got = fn(A)
        tol = _tol(A, ref)
        err = float(np.max(np.abs(got - ref)))
        assert np.all(np.isfinite(got)) and err <= tol, (
            f"{route} expm: error {err:.3g} > {tol:.3g} at ||A||_1 = {np.linalg.norm(A, 1):.3g}"
        )


@pytest.mark.parametrize("r", [3.0, 4.0, 8.0, 16.0])
def test_scipy_defect_reproducer(r):
    """``[[r, 0.1], [0.1, 0]]`` (symmetric: exp is perfectly conditioned) where scipy 1.17.1's expm
    errs by 253-9338 ulp: the house's and the judge's expm, and the judge's phi1 of ``[[r]]`` against
    ``expm1(r) / r``, within the model (at most ~100 ulp here)."""
    A = np.array([[r, 0.1], [0.1, 0.0]])
    ref = _exact_exp(A).real
    for fn in (expm, float_judge.expm):
        err = float(np.max(np.abs(fn(A) - ref)))
        assert err <= _tol(A, ref), (fn.__module__, r, err)
    p = float_judge.phi1(np.array([[r]]))[0, 0]
    exact = float(mpmath.expm1(r) / r)
    assert abs(p - exact) <= _tol(np.array([[r]]), np.array([[exact]]))


def test_expm_batched_and_no_mutation():
    """A stack gives each matrix's own exponential (one scaling for the stack: within the model), and
    the caller's array is unchanged."""
    stack = np.stack([MATRICES[3], 0.01 * MATRICES[3]])
    keep = stack.copy()
    got = expm(stack)
    assert np.array_equal(stack, keep)
    for i in range(2):
        ref = _exact_exp(stack[i]).real
        assert float(np.max(np.abs(got[i] - ref))) <= _tol(stack[0], ref)


@pytest.mark.parametrize("k", range(len(MATRICES)))
def test_mpmath_series_and_van_loan_agree(k):
    M = MATRICES[k]
    extra = int(np.linalg.norm(M, 1) / math.log(10)) + 5
    with mpmath.workdps(DPS + extra):
        a, b = phi1_mp(_mp(M)), phi1_mp_vanloan(_mp(M))
        scale = max(mpmath.mpf(1), mpmath.mnorm(b, mpmath.inf))
        assert mpmath.mnorm(a - b, mpmath.inf) <= mpmath.mpf(10) ** (-(DPS - 3)) * scale


def test_closed_forms():
    """``phi1(a) = expm1(a)/a`` (scalars; expm1 is correctly rounded to ~1 ulp, the quotient adds
    one rounding, the route ``8 eps expm_route(|a|)``); ``phi1(N) = 1 + N/2 + N^2/6`` exactly when
    ``N^3 = 0``; ``phi1(tJ) = 1 + (1 - cos t)/t J + (t - sin t)/t J^2`` for a rotation generator
    ``J`` (``J^3 = -J``)."""
    for a in (-7.0, -1e-3, 1e-9, 0.5, 2.0, 6.0):
        want = math.expm1(a) / a
        got = float(phi1(np.array([[a]]))[0, 0])
        assert abs(got - want) <= C_CERT * EPS64 * expm_route(abs(a)) * max(1.0, abs(want)), (
            a,
            got,
            want,
        )
    N = np.array([[0.0, 2.0, -3.0], [0.0, 0.0, 5.0], [0.0, 0.0, 0.0]])
    want = (
        np.eye(3) + N / 2 + N @ N / 6
    )  # exact in binary (small integers over 2 and 6: one rounding)
    assert np.max(np.abs(phi1(N) - want)) <= C_CERT * 3 * EPS64 * expm_route(8.0) * 5.0
    J = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    for t in (0.3, 2.5, 6.0):
        want = np.eye(3) + (1 - math.cos(t)) / t * J + (t - math.sin(t)) / t * (J @ J)
        got = phi1(t * J)
        assert np.max(np.abs(got - want)) <= C_CERT * 3 * EPS64 * expm_route(t) * 2.0, t


def test_batched_equals_per_point_within_the_model():
    """A batch shares one scaling ``s`` (from its largest norm); each point still meets the model."""
    batch = np.stack([MATRICES[k] for k in range(5, 10)])  # n = 3, the five norms
    got = phi1(batch)
    assert got.shape == batch.shape
    for M, G in zip(batch, got, strict=True):
        ref = _exact(M)
        # the batch's scaling is that of its largest member: the squarings count against ||M_max||
        tol = _tol(batch[-1], ref)
        assert np.max(np.abs(G - ref)) <= tol


def test_taylor_coefficients_and_no_mutation():
    assert np.array_equal(PHI1_TAYLOR, [1.0 / math.factorial(k + 1) for k in range(17)])
    assert not PHI1_TAYLOR.flags.writeable
    M = MATRICES[8].copy()
    keep = M.copy()
    phi1(M)
    assert np.array_equal(M, keep)
