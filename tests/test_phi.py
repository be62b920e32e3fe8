"""The house's phi1 (refimpl/_phi.py, ``phi1(M) = sum_k M^k/(k+1)! = (e^M - 1)/M``): the float64
route against the mpmath series at 40 digits, the mpmath series against the reference's second
mpmath route (Van Loan's block in mpmath), and both against closed forms (scalar ``expm1(a)/a``, a
nilpotent ``N`` with ``N^3 = 0``, a rotation generator).

The float judge's route (scipy's expm of Van Loan's block, oracles/float_judge.py) stays apart on
purpose and is not compared here: scipy 1.17.1's expm errs by ~2400 ulp at ``||A||_1 = 4`` (e.g.
``[[4, 1], [0, 0]]``), beyond the model below (NOTICES.md, 09:16 sot).

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

from tstarg.oracles.float_judge import C_CERT, EPS64, expm_route
from tstarg.refimpl._phi import PHI1_TAYLOR, phi1, phi1_mp, phi1_mp_vanloan

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
