"""The error estimate of the compiled full state (refimpl._full_state) bounds the answer's error.

Definition checked: ``full_state_flow`` returns per trajectory an ``error_estimate`` (the two-run
control's ``|A - B|`` or its proportional form, plus the rounding floor ``ROUND_PER_STEP`` and the
logarithm's measured ``|Ad(exp x) - Ad(g_B)|``) that is at most the tolerance and at least the error of
what the user reads: ``max(|pi - pi_ref|, |Ad(exp x) - Ad(exp x_ref)|)``.

Independent route: the mpmath reference flow (its own field in the chart ``(x, pi)`` with re-basing,
Gragg-Bulirsch-Stoer at 20 digits, its own logarithm), rounded to float64.

Error model of the comparison itself: ``Ad(exp x)`` of both ``x`` and ``x_ref`` is evaluated by mpmath
at 30 digits and rounded to float64 (a few ``eps |Ad|``); the reference's own error at 20 digits is
below ``1e-18``. The estimate must cover the rest: the flow's error and the logarithm's.
"""

from __future__ import annotations

import functools

import mpmath
import numpy as np
import pytest

from tstarg.refimpl import _full_state as fs_mod
from tstarg.refimpl._catalogue import catalogue
from tstarg.refimpl.flows import cached_model, reference_flow
from tstarg.refimpl.flows._common import _AbelianPart
from tstarg.reports import _bench_protocol as bp

EPS = np.finfo(float).eps
needs_numba = pytest.mark.skipif(not fs_mod._ct.HAVE_NUMBA, reason="numba not importable")


def _problem(name):
    """(f, Theta, Upsilon, inertia, x0, pi0, T): the bench's Bianchi VI0 with a cocycle (its
    logarithm ill-conditioned: ``Ad(g)`` grows like ``e^|t|``) and Manakov's top, over short times (the reference costs ~5 s each)."""
    if name == "bianchi_cocycle":
        p = bp.protocol_problem(name)
        return p.f, p.theta, p.upsilon, p.inertia, p.x0, p.pi0, 3.0
    alg = catalogue("so(4)")
    j = np.array([1.0, 1.7, 2.3, 3.1])
    pairs = [(i, k) for i in range(4) for k in range(i + 1, 4)]
    z = np.zeros((6, 6))
    rng = np.random.default_rng(4)
    f = np.array(alg.f, dtype=float)
    return f, z, z, np.diag([j[i] + j[k] for i, k in pairs]), 0.3 * rng.standard_normal(6), \
        3.0 * rng.standard_normal(6), 1.5  # fmt: skip


@functools.lru_cache(maxsize=None)
def _reference(name):
    f, theta, ups, inertia, x0, pi0, T = _problem(name)
    xr, pir = reference_flow(f, theta, ups, inertia, None, x0, pi0, T, dps=20)
    return np.asarray(xr, float), np.asarray(pir, float)


def _ad(f, x):
    """``Ad(exp x) = exp(ad_x)`` by mpmath at 30 digits (scipy's float64 ``expm`` errs by thousands of
    ulp on some matrices of 1-norm 3-16, scipy issue 25864), rounded to float64."""
    X = np.einsum("a,mab->mb", np.asarray(x, float), f)
    with mpmath.workdps(30):
        E = mpmath.expm(mpmath.matrix(X.tolist()))
        return np.array(E.tolist(), dtype=float)


@needs_numba
@pytest.mark.parametrize("name", ["bianchi_cocycle", "manakov_so4"])
@pytest.mark.parametrize("tol", [1e-10, 1e-12])
def test_estimate_bounds_the_error(name, tol):
    f, theta, ups, inertia, x0, pi0, T = _problem(name)
    model = cached_model(f, theta, ups, inertia, None)
    r = fs_mod.full_state_flow(model, x0[:, None], pi0[:, None], T, tol, abelian=_AbelianPart)
    est = float(r["error_estimate"][0])
    assert np.isfinite(est) and 0 < est <= tol
    xr, pir = _reference(name)  # one reference per problem for both tolerances
    x, pi = r["x"][:, 0], r["pi"][:, 0]
    Ad, Adr = _ad(f, x), _ad(f, xr)
    judge = 4 * EPS * max(1.0, np.max(np.abs(Adr)))  # the two roundings to float64, and the slack
    err = max(np.max(np.abs(pi - pir)), np.max(np.abs(Ad - Adr)))
    assert err <= est + judge, (err, est, judge)
    assert np.max(np.abs(x - xr)) <= 1e-6 * max(1.0, np.max(np.abs(xr)))  # the same branch of log


@needs_numba
@pytest.mark.parametrize("name", ["bianchi_cocycle", "manakov_so4"])
def test_batch_estimate_bounds_the_error_on_every_row(name):
    """The same bound through the batch path (the lane kernel, ``N = LANES + 1``, and the control's
    per-row floor with each row's logarithm residual): every row starts where the single trajectory
    does, so every row's estimate must bound that row's error against the same reference."""
    f, theta, ups, inertia, x0, pi0, T = _problem(name)
    model = cached_model(f, theta, ups, inertia, None)
    N = fs_mod._fsb.LANES + 1
    X0, P0 = np.repeat(x0[:, None], N, axis=1), np.repeat(pi0[:, None], N, axis=1)
    r = fs_mod.full_state_flow(model, X0, P0, T, 1e-10, abelian=_AbelianPart)
    xr, pir = _reference(name)
    Adr = _ad(f, xr)
    judge = 4 * EPS * max(1.0, np.max(np.abs(Adr)))
    for k in range(N):
        est = float(r["error_estimate"][k])
        assert np.isfinite(est) and 0 < est <= 1e-10
        x, pi = r["x"][:, k], r["pi"][:, k]
        err = max(np.max(np.abs(pi - pir)), np.max(np.abs(_ad(f, x) - Adr)))
        assert err <= est + judge, (k, err, est, judge)
