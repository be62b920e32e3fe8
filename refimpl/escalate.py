"""Answers within a requested tolerance: the fast implementation, escalated to mpmath where its bound is too loose.

The error model of :mod:`refimpl.fast`
--------------------------------------
For every point of a batch the fast implementation returns, besides ``P``
(or ``xdot``, ``pidot``), a bound on its own error in the max norm,

    ``error_bound = C_P n eps max(cond_phi, cond_data) frame_cond scale``,

with ``C_P = 16``, ``eps = 2^-52``; ``cond_phi = ||Phi||_F ||Phi^-1||_F / n``
for ``Phi = 1 + S Upsilon`` (vier6); ``cond_data = ||Phi^-1||_F (1 + ||S||_F
||Upsilon||_F) / sqrt(n)``, the sensitivity of ``Phi^-1`` to the rounding of
its data ``S = pi.f - Theta`` (vier3) and ``Upsilon``; ``frame_cond =
1/(1 - r)``, ``r = ||ad_x||/2pi`` (the chart of exponential coordinates ends
where ``phi1(-ad_x)`` is singular, twee1); ``scale = max(1, max_ij |P_ij|)``
(for the vector field ``max(1, |xdot|, |pidot|) max(1, ||L(g,e)||)``), plus,
on the generic path, the rounding of forming ``S = pi.f - Theta`` and ``ad_x``
from the magnitudes of their summands (see :mod:`refimpl.fast`).
Points with ``max(cond_phi, cond_data) n C_P eps >= 1`` lie on the degenerate
set ``Pi_1 = {Delta = det Phi = 0}`` (vier12) *to float64 accuracy*; the fast
implementation returns NaN there with ``error_bound = inf``.

The contract of this module
---------------------------
Given a tolerance ``tol``, the allowed error of point ``k`` is

* ``relative=True`` (default): ``allowed_k = tol * max(1, max_ij |P_k,ij|)``
  (mixed absolute/relative, the same scale as the error model and as the
  "correct digits" of docs/conventions.md);
* ``relative=False``: ``allowed_k = tol``.

Every point of the batch ends in exactly one of three states, and none is
dropped (outputs keep the batch shape):

``ok``
    ``error_bound_k <= allowed_k``: the fast value is returned as it is.
``escalated`` (``escalate=True``)
    the point is recomputed by the mpmath :class:`~refimpl.reference.Reference`
    on the *same* float64 inputs (taken as exact binary numbers) on a
    precision ladder ``d, d + 16`` digits; it is accepted when the two rungs
    agree to ``allowed_k / 8``. The returned ``error_bound`` is then that
    difference (an upper estimate of the lower rung's error, hence of the
    higher rung's) plus the rounding of the result to float64,
    ``eps/2 max_ij |P_k,ij|``. The first rung is
    ``d = 20 + log10(cond) + log10(1/tol_rel)`` with ``cond`` the fast
    ``max(cond_phi, cond_data) frame_cond``, or, where the fast implementation
    saw a degenerate point, ``cond = max(1, ||Phi||_F)^n / |Delta|`` with
    ``Delta`` computed exactly in rational arithmetic (sympy). The reference
    itself adds 12 guard digits.
``flagged``
    the point is returned but marked: with ``escalate=False`` every point
    whose bound exceeds ``allowed_k`` is flagged (the fast value is kept);
    with ``escalate=True`` a point is flagged only when escalation cannot
    give a trustworthy value: ``Delta = 0`` exactly (the point is on the
    degenerate set ``Pi_1``; no Poisson tensor exists, vier12), the point
    lies outside the chart of exponential coordinates (``max |Im eigenvalue
    of ad_x| >= 2 pi``, su(2): ``|x| >= 2 pi``; checked here before any
    work, whatever the fast implementation returned, and then NaN with
    ``error_bound = inf``), the reference refuses the point, the ladder reaches
    ``max_dps`` without two agreeing rungs, or float64 rounding alone
    exceeds ``allowed_k``. Values at flagged degenerate points are NaN and
    their ``error_bound`` is ``inf``.

Hence: every point that is not flagged has ``error_bound <= allowed``.
``tstarg stress`` checks this against an independent, higher-precision judge.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import mpmath
import numpy as np
import sympy

from . import fast as _fast_module
from ._algebra import LieAlgebra
from ._errors import DegeneratePointError
from ._reference_core import MAX_DPS
from ._validate import (
    check_inertia,
    check_points,
    check_potential,
    check_structure_constants,
    check_theta,
    check_upsilon,
    outside_chart,
)
from .reference import Reference

__all__ = [
    "LADDER_STEP",
    "FieldWithin",
    "PoissonWithin",
    "delta_exact",
    "poisson_within",
    "vector_field_within",
]

EPS = float(np.finfo(float).eps)
LADDER_STEP = 16  # digits between the two rungs of the precision ladder
DEFAULT_MAX_DPS = 400  # the ladder gives up (flags the point) beyond this precision


@dataclass(frozen=True)
class _Within:
    """What both results share: per-point bounds, tolerances, states, and the fast result."""

    error_bound: np.ndarray
    allowed: np.ndarray
    flagged: np.ndarray
    escalated: np.ndarray
    dps: np.ndarray
    reason: np.ndarray
    fast: Any
    tol: float
    relative: bool


@dataclass(frozen=True)
class PoissonWithin(_Within):
    """Poisson tensors within ``allowed`` or flagged (module docstring).

    ``P``: ``(..., 2n, 2n)``; ``error_bound``, ``allowed``: ``(...)``;
    ``flagged``, ``escalated``: boolean ``(...)``; ``dps``: the precision of the
    accepted rung (0 where not escalated); ``reason``: object array of short
    texts ("" for ok points); ``fast``: the fast implementation's batch result.
    """

    P: np.ndarray


@dataclass(frozen=True)
class FieldWithin(_Within):
    """Hamiltonian vector fields within ``allowed`` or flagged (see :class:`PoissonWithin`)."""

    xdot: np.ndarray
    pidot: np.ndarray


# ------------------------------------------------------------------ helpers
def _check_tol(tol) -> float:
    try:
        v = float(tol)
    except (TypeError, ValueError):
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}")
    return v


def _check_dps(dps, max_dps) -> None:
    if dps is not None and (
        not isinstance(dps, (int, np.integer)) or isinstance(dps, bool) or not 15 <= dps <= MAX_DPS
    ):
        raise ValueError(
            f"dps must be None or an int in [15, {MAX_DPS}] (the reference's cap), got {dps!r}"
        )
    if (
        not isinstance(max_dps, (int, np.integer))
        or isinstance(max_dps, bool)
        or not 30 <= max_dps <= MAX_DPS
    ):
        raise ValueError(
            f"max_dps must be an int in [30, {MAX_DPS}] (the reference's cap), got {max_dps!r}"
        )


def _fast_impl(fast):
    if fast is not None:
        return fast
    return (
        _fast_module.implementation
    )  # looked up at call time: a replaced implementation is honoured


def _model(f, theta, upsilon):
    """The float64 problem both implementations solve (a LieAlgebra is taken by its float ``f``)."""
    ff = check_structure_constants(f.f if isinstance(f, LieAlgebra) else f)
    th = check_theta(theta, ff)
    up = check_upsilon(upsilon, ff.shape[0])
    return ff, th, up


def delta_exact(f, theta, upsilon, pi) -> sympy.Rational:
    """``Delta = det(1 + S Upsilon)``, ``S = pi_m f^m - Theta`` (vier3, vier7), exactly.

    Every float64 input is a binary rational; ``sympy.Rational(float)`` is
    exact, so the determinant (Bareiss) is the exact Delta of the float64
    problem. ``Delta == 0`` means the point lies on ``Pi_1`` (vier12).
    """
    ff, th, up = _model(f, theta, upsilon)
    n = ff.shape[0]
    p = [sympy.Rational(float(v)) for v in np.asarray(pi, dtype=float).reshape(n)]
    F = [
        [[sympy.Rational(float(ff[m, a, b])) for b in range(n)] for a in range(n)] for m in range(n)
    ]
    S = sympy.Matrix(
        n,
        n,
        lambda a, b: sum(p[m] * F[m][a][b] for m in range(n)) - sympy.Rational(float(th[a, b])),
    )
    U = sympy.Matrix(n, n, lambda a, b: sympy.Rational(float(up[a, b])))
    return (sympy.eye(n) + S * U).det(method="bareiss")


def _phi_norm(f, theta, upsilon, pi) -> float:
    ff, th, up = _model(f, theta, upsilon)
    S = np.einsum("m,mab->ab", np.asarray(pi, dtype=float), ff) - th
    return float(np.linalg.norm(np.eye(ff.shape[0]) + S @ up))


def _start_dps(cond: float, tol_rel: float, dps: int | None) -> int:
    if dps is not None:
        return int(dps)
    c = cond if math.isfinite(cond) and cond > 1 else 1.0
    return int(20 + math.ceil(math.log10(c)) + math.ceil(max(0.0, -math.log10(tol_rel))))


def _max_abs(values, prec_dps: int):
    with mpmath.workdps(prec_dps):
        return max([mpmath.mpf(0)] + [abs(v) for v in values])


def _ladder(evaluate: Callable[[int], list], d0: int, max_dps: int, tol: float, relative: bool):
    """Run the precision ladder. Returns ``(values as float64, bound, dps, "")`` or ``(None, inf, 0, reason)``.

    ``evaluate(d)`` returns the flat list of mpmath results at ``d`` digits, or
    raises :class:`DegeneratePointError` / ``ValueError``.
    """
    d = max(20, d0)
    prev, prev_d = None, None
    last_reason = "no rung reached"
    while d <= max_dps:
        try:
            vals = evaluate(d)
        except DegeneratePointError:
            # Delta below the reference's rounding noise at d digits: more digits may resolve it
            prev, last_reason = None, f"degenerate to {d} digits"
            d *= 2
            continue
        except ValueError as exc:  # outside the chart of exponential coordinates
            return None, math.inf, 0, f"reference refused the point: {str(exc)[:120]}"
        except TypeError as exc:
            # mpmath 1.3's LU raises TypeError when a pivot column is exactly zero (mpmath issue
            # #542): Phi is exactly singular, the point is on Pi_1.
            if "NoneType" not in str(exc):
                raise
            return None, math.inf, 0, "Phi exactly singular (mpmath #542 TypeError in det)"
        if prev is not None:
            with mpmath.workdps(d + 20):
                diff = max(abs(mpmath.mpf(a) - mpmath.mpf(b)) for a, b in zip(vals, prev))
                scale = max(mpmath.mpf(1), _max_abs(vals, d + 20))
            allowed = tol * float(scale) if relative else tol
            rounding = EPS / 2 * float(scale)
            if rounding > allowed:
                return (
                    None,
                    math.inf,
                    0,
                    f"float64 rounding {rounding:.2g} alone exceeds the allowed {allowed:.2g}",
                )
            if float(diff) <= allowed / 8:
                out = np.array([float(v) for v in vals])
                return out, float(diff) + rounding, d, ""
            last_reason = f"rungs {prev_d} and {d} digits differ by {float(diff):.2g}"
        prev, prev_d = vals, d
        d += LADDER_STEP
    return None, math.inf, 0, f"precision ladder reached max_dps = {max_dps} ({last_reason})"


def _resolve(
    n_points: int,
    values: np.ndarray,
    bound: np.ndarray,
    degenerate: np.ndarray,
    cond: np.ndarray,
    tol: float,
    relative: bool,
    escalate: bool,
    dps: int | None,
    max_dps: int,
    evaluate_point: Callable[[int, int], list],
    exact_cond: Callable[[int], float],
    outside: np.ndarray | None = None,
):
    """Shared logic: decide ok / escalated / flagged per point. ``values``: (N, m) float64, modified in place.
    ``outside``: points outside the chart, flagged at once (NaN, bound inf)."""
    with np.errstate(invalid="ignore", over="ignore"):
        scale = np.maximum(1.0, np.max(np.abs(values), axis=1)) if relative else np.ones(n_points)
    scale = np.where(np.isfinite(scale), scale, np.inf)
    allowed = tol * scale if relative else np.full(n_points, tol)
    bound = np.where(np.isfinite(bound), bound, np.inf).astype(float)
    over = ~(bound <= allowed) | degenerate | ~np.all(np.isfinite(values), axis=1)
    flagged = np.zeros(n_points, dtype=bool)
    escalated = np.zeros(n_points, dtype=bool)
    used = np.zeros(n_points, dtype=int)
    reason = np.full(n_points, "", dtype=object)
    if outside is not None and outside.any():
        values[outside] = np.nan
        bound[outside] = np.inf
        flagged[outside] = True
        reason[outside] = (
            "outside the chart of exponential coordinates (max |Im eig ad_x| >= 2 pi, twee1)"
        )
        over &= ~outside
    for k in np.flatnonzero(over):
        if not escalate:
            flagged[k] = True
            reason[k] = (
                "degenerate to float64 accuracy"
                if degenerate[k]
                else "error bound exceeds the tolerance"
            )
            continue
        if degenerate[k] or not math.isfinite(float(cond[k])):
            c = exact_cond(k)
            if c == math.inf:
                flagged[k], reason[k] = (
                    True,
                    "Delta = 0 exactly: on the degenerate set Pi_1 (vier12)",
                )
                values[k] = np.nan
                bound[k] = np.inf
                continue
        else:
            c = float(cond[k])
        d0 = _start_dps(
            c,
            tol if relative else tol / max(1.0, float(scale[k]) if np.isfinite(scale[k]) else 1.0),
            dps,
        )
        out, b, d, why = _ladder(lambda d, k=k: evaluate_point(k, d), d0, max_dps, tol, relative)
        if out is None:
            flagged[k], reason[k] = True, why
            if degenerate[k]:
                values[k] = np.nan
                bound[k] = np.inf
            continue
        values[k] = out
        bound[k] = b
        allowed[k] = tol * max(1.0, float(np.max(np.abs(out)))) if relative else tol
        escalated[k], used[k], reason[k] = True, d, "escalated to mpmath"
    allowed = np.where(np.isfinite(allowed), allowed, np.nan)  # undefined where the value is (NaN)
    return values, bound, allowed, flagged, escalated, used, reason


def _exact_cond_fn(ff, th, up, pi_pts):
    def exact_cond(k: int) -> float:
        delta = delta_exact(ff, th, up, pi_pts[k])
        if delta == 0:
            return math.inf
        n = ff.shape[0]
        nrm = max(1.0, _phi_norm(ff, th, up, pi_pts[k]))
        # cond ~ ||Phi||^n / |Delta| (Delta is the product of Phi's eigenvalues); in logs to avoid overflow
        log_c = n * math.log10(nrm) - float(sympy.log(abs(delta), 10).evalf(20))
        return 10.0 ** min(max(log_c, 0.0), 300.0)

    return exact_cond


# ------------------------------------------------------------ Poisson tensor
def poisson_within(
    f,
    theta,
    upsilon,
    x,
    pi,
    tol,
    *,
    escalate: bool = True,
    dps: int | None = None,
    relative: bool = True,
    max_dps: int = DEFAULT_MAX_DPS,
    fast=None,
) -> PoissonWithin:
    """Holonomic Poisson tensors ``P[..., i, j] = {z_i, z_j}`` (vier9) within ``tol``, or flagged.

    Calls ``fast.poisson_batch`` (default :data:`refimpl.fast.implementation`,
    looked up at call time) on the whole batch, then treats every point whose
    ``error_bound`` exceeds its allowed error as the module docstring says:
    escalated to :class:`~refimpl.reference.Reference` (``escalate=True``) or
    flagged (``escalate=False``). ``dps`` fixes the first rung of the ladder.
    """
    tol = _check_tol(tol)
    _check_dps(dps, max_dps)
    ff, th, up = _model(f, theta, upsilon)
    n = ff.shape[0]
    xa, pa = check_points(x, pi, n, batched=True)
    shape = xa.shape[:-1]
    N = int(np.prod(shape, dtype=int))
    fast = _fast_impl(fast)
    res = fast.poisson_batch(ff, th, up, xa, pa)
    values = np.array(res.P, dtype=float).reshape(N, 4 * n * n)
    X, Pm = xa.reshape(N, n), pa.reshape(N, n)
    with np.errstate(invalid="ignore", over="ignore"):
        cond = np.maximum(
            np.asarray(res.cond_phi, dtype=float), np.asarray(res.cond_data, dtype=float)
        ).reshape(N)

    def evaluate(k: int, d: int) -> list:
        M = Reference(d).poisson_tensor_mp(ff, th, up, X[k], Pm[k])
        return [M[i, j] for i in range(2 * n) for j in range(2 * n)]

    values, bound, allowed, flagged, escalated, used, reason = _resolve(
        N,
        values,
        np.asarray(res.error_bound, dtype=float).reshape(N).copy(),
        np.asarray(res.degenerate, dtype=bool).reshape(N),
        cond,
        tol,
        relative,
        escalate,
        dps,
        max_dps,
        evaluate,
        _exact_cond_fn(ff, th, up, Pm),
        outside_chart(ff, X),
    )
    return PoissonWithin(
        P=values.reshape(shape + (2 * n, 2 * n)),
        error_bound=bound.reshape(shape),
        allowed=allowed.reshape(shape),
        flagged=flagged.reshape(shape),
        escalated=escalated.reshape(shape),
        dps=used.reshape(shape),
        reason=reason.reshape(shape),
        fast=res,
        tol=tol,
        relative=relative,
    )


# -------------------------------------------------------------- vector field
def vector_field_within(
    f,
    theta,
    upsilon,
    inertia,
    potential,
    x,
    pi,
    tol,
    *,
    escalate: bool = True,
    dps: int | None = None,
    relative: bool = True,
    max_dps: int = DEFAULT_MAX_DPS,
    fast=None,
) -> FieldWithin:
    """``(xdot, pidot)`` of vier10/vier11 within ``tol``, or flagged (module docstring).

    The allowed error of point ``k`` is ``tol * max(1, |xdot_k|_max, |pidot_k|_max)``
    (``relative=True``) or ``tol``; escalation uses
    :meth:`~refimpl.reference.Reference.hamiltonian_vector_field_mp`.
    """
    tol = _check_tol(tol)
    _check_dps(dps, max_dps)
    ff, th, up = _model(f, theta, upsilon)
    n = ff.shape[0]
    inertia = check_inertia(inertia, n)
    pot = check_potential(potential, n)
    xa, pa = check_points(x, pi, n, batched=True)
    shape = xa.shape[:-1]
    N = int(np.prod(shape, dtype=int))
    fast = _fast_impl(fast)
    res = fast.vector_field_batch(ff, th, up, inertia, pot, xa, pa)
    values = np.concatenate(
        [
            np.asarray(res.xdot, dtype=float).reshape(N, n),
            np.asarray(res.pidot, dtype=float).reshape(N, n),
        ],
        axis=1,
    )
    X, Pm = xa.reshape(N, n), pa.reshape(N, n)
    with np.errstate(invalid="ignore", over="ignore"):
        cond = np.maximum(
            np.asarray(res.cond_phi, dtype=float), np.asarray(res.cond_data, dtype=float)
        ).reshape(N)

    def evaluate(k: int, d: int) -> list:
        xd, pd = Reference(d).hamiltonian_vector_field_mp(ff, th, up, inertia, pot, X[k], Pm[k])
        return [xd[i] for i in range(n)] + [pd[i] for i in range(n)]

    values, bound, allowed, flagged, escalated, used, reason = _resolve(
        N,
        values,
        np.asarray(res.error_bound, dtype=float).reshape(N).copy(),
        np.asarray(res.degenerate, dtype=bool).reshape(N),
        cond,
        tol,
        relative,
        escalate,
        dps,
        max_dps,
        evaluate,
        _exact_cond_fn(ff, th, up, Pm),
        outside_chart(ff, X),
    )
    return FieldWithin(
        xdot=values[:, :n].reshape(shape + (n,)),
        pidot=values[:, n:].reshape(shape + (n,)),
        error_bound=bound.reshape(shape),
        allowed=allowed.reshape(shape),
        flagged=flagged.reshape(shape),
        escalated=escalated.reshape(shape),
        dps=used.reshape(shape),
        reason=reason.reshape(shape),
        fast=res,
        tol=tol,
        relative=relative,
    )
