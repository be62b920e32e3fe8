"""Integrators: one at arbitrary precision (the reference), several in float64 (batched).

Reference (mpmath)
    :func:`gbs_mp` -- Gragg-Bulirsch-Stoer extrapolation: the modified
    midpoint rule with ``n_j = 2 j`` substeps (``j = 1..k``) has an error
    expansion in even powers of ``h/n_j``; Aitken-Neville extrapolation of
    ``k`` such values has local error ``O(h^(2k+1))`` (order ``2k``). The
    difference of the last two diagonal entries of the tableau estimates the
    local error; steps are accepted when it is below ``tol`` and resized by
    ``h <- 0.9 h (tol/err)^(1/(2k))``. Explicit, so it runs at any precision
    with no implicit solve. The caller confirms the result by a precision and
    tolerance ladder (see :mod:`refimpl.flows.reference`).

Fast (numpy float64, the state is an array whose leading axis is the component
and whose trailing axes are the batch)
    :class:`ExplicitRK` with the DOP853 tableau of Dormand and Prince (taken
    from ``scipy.integrate._ivp.dop853_coefficients``, order 8) or the classical
    RK4 (order 4); :class:`GaussLegendre` (``s`` stages, order ``2s``, implicit
    midpoint is ``s = 1``; symplectic, solved by fixed-point iteration to
    rounding); :func:`triple_jump` -- Yoshida's composition
    ``Psi_{g1 h} Psi_{g0 h} Psi_{g1 h}``, ``g1 = 1/(2 - 2^(1/(p+1)))``,
    ``g0 = 1 - 2 g1``, which raises a symmetric method of order ``p`` to order
    ``p + 2`` (used for the Lie-Poisson splittings).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import mpmath
import numpy as np
from scipy.integrate._ivp import dop853_coefficients as d

__all__ = [
    "gbs_mp",
    "GBSResult",
    "ExplicitRK",
    "GaussLegendre",
    "triple_jump_weights",
    "DOP853",
    "RK4",
]


# ------------------------------------------------------------------ mpmath
@dataclass
class GBSResult:
    y: list
    steps: int
    rejected: int
    evaluations: int
    max_local_error: object


def _gbs_step(F, t, y, h, k):
    """One extrapolated step; returns (y_new, error estimate, evaluations)."""
    d = len(y)
    f0 = F(t, y)
    evals = 1
    T = []
    ns = [2 * (j + 1) for j in range(k)]
    for j, nj in enumerate(ns):
        hh = h / nj
        z0 = list(y)
        z1 = [y[i] + hh * f0[i] for i in range(d)]
        for m in range(1, nj):
            fz = F(t + m * hh, z1)
            evals += 1
            z0, z1 = z1, [z0[i] + 2 * hh * fz[i] for i in range(d)]
        fz = F(t + h, z1)
        evals += 1
        row = [[(z1[i] + z0[i] + hh * fz[i]) / 2 for i in range(d)]]
        for i in range(1, j + 1):
            r = mpmath.mpf(ns[j]) ** 2 / mpmath.mpf(ns[j - i]) ** 2 - 1
            prev = T[j - 1][i - 1]
            cur = row[i - 1]
            row.append([cur[c] + (cur[c] - prev[c]) / r for c in range(d)])
        T.append(row)
    best = T[k - 1][k - 1]
    err = max(abs(best[c] - T[k - 1][k - 2][c]) for c in range(d))
    scale = max([mpmath.mpf(1)] + [abs(v) for v in best])
    return best, err / scale, evals


def gbs_mp(
    F: Callable,
    y0: Sequence,
    t_end,
    *,
    tol,
    k: int,
    h0=None,
    t0=0,
    after_step: Callable | None = None,
    max_steps: int = 200000,
) -> GBSResult:
    """Integrate ``y' = F(t, y)`` (lists of mpf) from ``t0`` to ``t_end`` at the current precision.

    ``after_step(t, y) -> y`` may replace the state between steps (re-basing
    of the configuration chart). ``tol`` is the per-step relative local error.
    """
    t = mpmath.mpf(t0)
    t_end = mpmath.mpf(t_end)
    y = [mpmath.mpf(v) for v in y0]
    h = mpmath.mpf(h0) if h0 is not None else min(mpmath.mpf("0.25"), t_end - t)
    steps = rejected = evals = 0
    worst = mpmath.mpf(0)
    order = 2 * k
    while t < t_end:
        if steps + rejected > max_steps:
            raise RuntimeError(f"gbs_mp: more than {max_steps} steps before t = {t_end}")
        h = min(h, t_end - t)
        y_new, err, ne = _gbs_step(F, t, y, h, k)
        evals += ne
        if err <= tol or h < mpmath.mpf(10) ** (-mpmath.mp.dps // 3):
            t = t + h if t_end - t - h > mpmath.eps * 10 else t_end
            y = y_new
            steps += 1
            worst = max(worst, err)
            if after_step is not None:
                y = after_step(t, y)
        else:
            rejected += 1
        fac = mpmath.mpf("0.9") * (tol / max(err, tol * mpmath.mpf(10) ** -12)) ** (
            mpmath.mpf(1) / order
        )
        h = h * min(mpmath.mpf(3), max(mpmath.mpf("0.2"), fac))
    return GBSResult(y=y, steps=steps, rejected=rejected, evaluations=evals, max_local_error=worst)


# ------------------------------------------------------------------- numpy
def _dop853_tableau():
    s = d.N_STAGES
    return (
        np.array(d.A[:s, :s], dtype=float),
        np.array(d.B, dtype=float),
        np.array(d.C[:s], dtype=float),
    )


def _rk4_tableau():
    A = np.zeros((4, 4))
    A[1, 0] = A[2, 1] = 0.5
    A[3, 2] = 1.0
    return A, np.array([1, 2, 2, 1]) / 6.0, np.array([0.0, 0.5, 0.5, 1.0])


class ExplicitRK:
    """Fixed-step explicit Runge-Kutta for ``y' = F(y)`` (autonomous), ``y`` of shape ``(d, ...)``.

    Obligations of ``F``: pure, shape-preserving, batched over trailing axes.
    """

    def __init__(self, name: str, tableau, order: int):
        self.name, self.order = name, order
        self.A, self.b, self.c = tableau
        self.stages = len(self.b)

    def step(self, F, y, h):
        K = np.empty((self.stages,) + y.shape)
        K[0] = F(y)
        for i in range(1, self.stages):
            a = self.A[i, :i]
            K[i] = F(y + h * np.tensordot(a, K[:i], axes=(0, 0)))
        return y + h * np.tensordot(self.b, K, axes=(0, 0))

    def integrate(self, F, y0, t, nsteps: int, after_step=None, observe=None, F_into=None):
        """``nsteps`` fixed steps; the stage sums are one ``dot`` each into preallocated buffers.

        ``F_into(y, out)``, when given, writes ``F(y)`` into ``out`` (no allocation per stage).
        """
        h = t / nsteps
        y = np.array(y0, dtype=float)
        s = self.stages
        K = np.empty((s,) + y.shape)
        Kf = K.reshape(s, -1)
        buf = np.empty(y.size)
        rows = [h * np.ascontiguousarray(self.A[i, :i]) for i in range(s)]
        b = h * np.ascontiguousarray(self.b)
        stage = buf.reshape(y.shape)
        for step in range(nsteps):
            yf = y.reshape(-1)
            if F_into is None:
                K[0] = F(y)
            else:
                F_into(y, K[0])
            for i in range(1, s):
                np.dot(rows[i], Kf[:i], out=buf)
                buf += yf
                if F_into is None:
                    K[i] = F(stage)
                else:
                    F_into(stage, K[i])
            np.dot(b, Kf, out=buf)
            y = y + stage
            if after_step is not None:
                y = after_step(y)
            if observe is not None:
                observe(step + 1, y)
        return y


DOP853 = ExplicitRK("dop853-fixed", _dop853_tableau(), 8)
RK4 = ExplicitRK("rk4", _rk4_tableau(), 4)


def _gauss_tableau(s: int):
    """Gauss-Legendre nodes ``c`` (roots of the shifted Legendre polynomial), ``A``, ``b``.

    ``b`` and ``A`` solve the simplifying conditions ``B(s)`` and ``C(s)``:
    ``sum_j b_j c_j^(q-1) = 1/q`` and ``sum_j a_ij c_j^(q-1) = c_i^q / q``.
    """
    x, _ = np.polynomial.legendre.leggauss(s)
    c = (x + 1) / 2
    V = np.vander(c, s, increasing=True).T  # V[q, j] = c_j^q
    q = np.arange(1, s + 1)
    b = np.linalg.solve(V, 1.0 / q)
    A = np.linalg.solve(V, (c[None, :] ** q[:, None] / q[:, None])).T
    return A, b, c


class GaussLegendre:
    """``s``-stage Gauss-Legendre collocation (order ``2s``; ``s = 1`` is the implicit midpoint rule).

    Symplectic for any symplectic structure written in canonical coordinates,
    and it preserves quadratic invariants exactly. The stage equations
    ``K_i = F(y + h sum_j a_ij K_j)`` are solved by fixed-point iteration until
    the update stops decreasing (rounding level) or ``max_iter``.
    """

    def __init__(self, s: int):
        self.s = s
        self.order = 2 * s
        self.name = "implicit-midpoint" if s == 1 else f"gauss-legendre-{s}"
        self.A, self.b, self.c = _gauss_tableau(s)

    def step(self, F, y, h, max_iter: int = 60):
        f0 = F(y)
        K = np.broadcast_to(f0, (self.s,) + y.shape).copy()
        last = np.inf
        for _ in range(max_iter):
            Y = y[None] + h * np.tensordot(self.A, K, axes=(1, 0))
            Knew = np.stack([F(Y[i]) for i in range(self.s)])
            upd = float(np.max(np.abs(Knew - K))) if K.size else 0.0
            K = Knew
            scale = float(np.max(np.abs(K))) if K.size else 0.0
            if upd <= 4 * np.finfo(float).eps * max(scale, 1e-300) or upd >= last:
                break
            last = upd
        return y + h * np.tensordot(self.b, K, axes=(0, 0))

    def integrate(self, F, y0, t, nsteps: int, after_step=None, observe=None):
        h = t / nsteps
        y = np.array(y0, dtype=float)
        for step in range(nsteps):
            y = self.step(F, y, h)
            if after_step is not None:
                y = after_step(y)
            if observe is not None:
                observe(step + 1, y)
        return y


def triple_jump_weights(order: int) -> list[float]:
    """Step fractions of the recursive triple jump raising a symmetric order-2 method to ``order``.

    ``order`` even >= 2; the result has ``3^(order/2 - 1)`` fractions summing to 1.
    """
    if order < 2 or order % 2:
        raise ValueError(f"order must be even and >= 2, got {order}")
    w = [1.0]
    p = 2
    while p < order:
        g1 = 1.0 / (2.0 - 2.0 ** (1.0 / (p + 1)))
        g0 = 1.0 - 2.0 * g1
        w = [g1 * v for v in w] + [g0 * v for v in w] + [g1 * v for v in w]
        p += 2
    return w
