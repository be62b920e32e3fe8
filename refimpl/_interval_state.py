"""The whole state of a flow in compiled double intervals: the fast route of the flow judge.

The state, the field and the start are those of :func:`refimpl._rigorous_state.full_state_enclosure`
(one definition, :func:`refimpl._rigorous_state._setup`): ``pi``, ``Gamma`` (gravity), ``G = rho(g)``
in the faithful representation with exact matrices (a complex one as its real and imaginary parts,
``G_r' = G_r R(Omega) - G_i J(Omega)``, ``G_i' = G_r J(Omega) + G_i R(Omega)``) and optionally
``Ad(g)``: a quadratic field whose body rows are :func:`refimpl._rigorous_flow.body_field`'s (the
tables of ``refimpl/_taylor.py``), built in Arb balls at :data:`SETUP_BITS`, its start
``(pi0, Ad(exp x0)^T gamma, exp(rho(x0)), exp(ad_x0))`` by Arb's rigorous matrix exponential. Every
coefficient and start value is rounded outward to a float64 interval
(:func:`refimpl._interval_flow.interval_tables`) and the state is carried by the compiled interval
Taylor method with Lohner's QR wrapping of :mod:`refimpl._interval_kernel` (its docstring proves the
outward rounding). ``g`` is carried as a matrix, so no chart and no re-basing is needed on the way;
``t < 0`` integrates the reversed field ``-F`` over ``|t|`` (exact: every coefficient negated).

At the end only, ``x`` (the principal logarithm of ``rho(g(t))``, the flows' documented choice (a)) is
proven from the box by the Arb route's Krawczyk test and Bendixson's strip bound
(:func:`refimpl._rigorous_state._principal_log`) at :data:`LOG_BITS`; where that fails ``x`` is None
and ``x_note`` names the reason. Several times of one sign are reached by continuing from the box of
the previous one (each segment starts from a box that contains the exact state, so each box is proven).

Refusals (``ValueError``, by name): ``Upsilon != 0`` (the field is rational: use
:func:`full_state_enclosure`), a step-size underflow, an overflow, more than ``max_steps`` steps
(:func:`refimpl._interval_flow.interval_enclose`), and every input refusal of the Arb route. The radius
floor is that of doubles: about ``1e-13`` relative at ``|t| = 10`` on the heavy top.
"""

from __future__ import annotations

import time
from fractions import Fraction

import numpy as np
from flint import arb

from ._arb import workprec
from ._interval_flow import (
    SETUP_BITS,
    _bounds,
    check_settings,
    interval_enclose,
    interval_tables,
)
from ._rigorous_state import StateEnclosure, _finish, _setup

__all__ = ["INTERVAL_METHOD", "LOG_BITS", "interval_state_enclosure", "interval_state_enclosures"]

LOG_BITS = 64
"""Precision of the Arb proof of ``x`` from the final box (the box is ~1e-16 wide or more: 64 bits
resolve it)."""

INTERVAL_METHOD = "float64 intervals, Lohner"
"""The method's name in :attr:`StateEnclosure.method` and in the judge's name."""


class UpsilonError(ValueError):
    """The interval route carries polynomial fields only: ``Upsilon != 0`` is the Arb route's."""


def interval_state_enclosures(
    f,
    theta,
    upsilon,
    inertia,
    potential,
    x0,
    pi0,
    times,
    *,
    tol: float = 1e-16,
    order: int | None = None,
    jac_order: int = 6,
    want_x: bool = True,
    want_ad: bool = False,
    max_steps: int = 100000,
) -> list[StateEnclosure]:
    """The whole state at every time of ``times`` (one sign; any order), each a
    :class:`StateEnclosure` whose balls contain the exact state (module docstring), in the order of
    ``times``. ``tol``: the largest Lagrange remainder accepted per step; ``order``: the Taylor order
    (default :func:`refimpl._interval_flow.default_order` of ``tol``); ``jac_order``: of the Jacobian
    series (at most ``order``). The inputs pass the Arb route's checks."""
    t_start = time.process_time()
    tol, order = check_settings(tol, order, jac_order, max_steps)
    tvals = [float(v) for v in np.asarray(times, dtype=float).reshape(-1)]
    if not tvals:
        raise ValueError("times must hold at least one time")
    if any(a > 0 for a in tvals) and any(a < 0 for a in tvals):
        raise ValueError(f"times must have one sign, got {tvals}")
    end = max(tvals, key=abs)
    with workprec(SETUP_BITS):
        S = _setup(f, theta, upsilon, inertia, potential, x0, pi0, end, SETUP_BITS, want_x, want_ad)
        if S.rational:
            raise UpsilonError(
                "interval route: Upsilon != 0 makes the field rational (the solve by Phi); the "
                "interval route carries polynomial fields only (use full_state_enclosure)"
            )
        tables = interval_tables(S.fld)
        b = [_bounds(v) for v in S.y0]
    lo = np.array([u for u, _ in b])
    hi = np.array([v for _, v in b])
    lo0, hi0 = lo, hi
    done: dict[float, tuple] = {}
    now, steps_total, rej_total = 0.0, 0, 0
    for ta in sorted({abs(v) for v in tvals}):
        if ta > now:
            # the segment [now, ta] from the box at now, when its length is exact in float64 (the
            # box at now contains y(now), so the box after ta - now contains y(ta)); else from 0
            d = ta - now
            if Fraction(d) != Fraction(ta) - Fraction(now):
                lo, hi, now, d = lo0, hi0, 0.0, ta
            lo, hi, steps, rejected = interval_enclose(
                tables, lo, hi, d, order=order, jac_order=jac_order, tol=tol, max_steps=max_steps
            )
            steps_total += steps
            rej_total += rejected
            now = ta
        done[ta] = (lo.copy(), hi.copy(), steps_total, rej_total)
    out = []
    with workprec(LOG_BITS):
        for tv in tvals:
            lo_t, hi_t, steps, rejected = done[abs(tv)]
            y = [arb(float(u)).union(arb(float(v))) for u, v in zip(lo_t, hi_t)]
            S.tv = tv
            e = _finish(S, y, LOG_BITS, steps, rejected, t_start, want_x)
            e.method = INTERVAL_METHOD
            out.append(e)
    return out


def interval_state_enclosure(
    f,
    theta,
    upsilon,
    inertia,
    potential,
    x0,
    pi0,
    t,
    *,
    tol: float = 1e-16,
    order: int | None = None,
    jac_order: int = 6,
    want_x: bool = True,
    want_ad: bool = False,
    max_steps: int = 100000,
) -> StateEnclosure:
    """The whole state at ``t`` (either sign) in float64 intervals (module docstring); the arguments
    of :func:`full_state_enclosure` (``Upsilon = 0`` only) and of :func:`interval_state_enclosures`."""
    (e,) = interval_state_enclosures(
        f, theta, upsilon, inertia, potential, x0, pi0, [t], tol=tol, order=order,
        jac_order=jac_order, want_x=want_x, want_ad=want_ad, max_steps=max_steps,
    )  # fmt: skip
    return e
