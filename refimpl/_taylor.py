"""Taylor-series integrators of high order for the polynomial body systems (``Upsilon = 0``).

The field
    With ``Upsilon = 0`` (``Phi = 1``, vier6) the body systems are quadratic
    polynomials in ``y = pi`` (Euler, twee14/drie6) or ``y = (pi, Gamma)``
    (Euler-Poisson, twee17 sign-corrected, twee18, with ``-dV`` of twee16)::

        pidot_a     = -pi_m f^m_ab w_b + Theta_ab w_b + Gamma_m f^m_ac L^c,   w = I^-1 pi
        Gammadot_mu = w_b f^a_{b mu} Gamma_a

    so, after eliminating ``w``, ``ydot_c = sum_{i<=j} Q_c,ij y_i y_j + sum_i
    Lin_c,i y_i`` (:func:`quadratic_field`; equal monomials merged, zero
    coefficients dropped).

The method
    Let ``Y_k = h^k y^(k)(t0) / k!`` be the scaled Taylor coefficients of the
    solution through ``y(t0) = Y_0``. Differentiating ``ydot = F(y)`` and
    matching powers of ``s`` in ``y(t0 + s h) = sum_k Y_k s^k`` gives, because
    the coefficient of ``s^k`` in a product of two series is their Cauchy
    product,

        Y_{k+1,c} = h / (k + 1) * ( sum_{i<=j} Q_c,ij sum_{a=0}^{k} Y_{a,i} Y_{k-a,j}
                                  + sum_i Lin_c,i Y_{k,i} ),

    an exact recurrence (no truncation, no nested differentiation). The
    method of order ``P`` takes ``y(t0 + h) ~ sum_{k=0}^{P} Y_k``: the local
    error is the tail ``sum_{k>P} Y_k = O(h^(P+1))``, the global error
    ``O(h^P)``; ``tests/test_flow_orders.py`` fits ``P``. Per step the cost is
    ``P (P + 1) / 2`` multiply-adds per distinct monomial, against ``s`` field
    evaluations plus ``s (s - 1) / 2`` stage sums of a ``s``-stage Runge-Kutta
    method: for the 6-dimensional heavy top, order 16-20 with steps near the
    series' radius of convergence costs a fraction of DOP853 at ``1e-9``.
    The construction (automatic differentiation of the field by recurrences
    for the Taylor coefficients) is the one of Jorba and Zou, "A software
    package for the numerical integration of ODEs by means of high-order
    Taylor methods", Experimental Mathematics 14 (2005) 99-117; for quadratic
    fields every recurrence is a Cauchy product.

Two kernels run the same arithmetic (rounding differs only in order):

* :func:`scalar_taylor_integrator` -- generated straight-line Python over floats
  for one trajectory: the whole step unrolled, coefficients as literals, only
  local names, the step loop inside the generated function. A component whose
  field is identically zero is constant, so its coefficients ``Y_{k>=1}`` are
  zero and every Cauchy-product term containing them is dropped. The code uses
  ``+ - * /`` and float literals only, so it also runs on ``mpmath.mpf``
  (used by the order test to see the truncation error far below float64).
* :func:`numpy_taylor_integrator` -- batched over trajectories (state ``(d, N)``),
  coefficients stored as ``(P + 1, d, N)``; per order one ``einsum`` per
  monomial (a Cauchy product over strided views), in-place ufuncs for the
  linear combinations, one matrix-vector product for the sum of the series.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import codegen
from ._lru import LRU

__all__ = [
    "CHUNK",
    "QuadraticField",
    "body_field_tables",
    "numpy_taylor_integrator",
    "quadratic_field",
    "quadratic_field_su2_full",
    "scalar_taylor_integrator",
]

CHUNK = (
    16384  # trajectories per chunk of the batched kernel (bounds the coefficient arrays' memory)
)


@dataclass(frozen=True)
class QuadraticField:
    """``ydot_c = sum quad[c][(i, j)] y_i y_j + sum lin[c][i] y_i`` with ``i <= j``; zeros dropped.

    The one quadratic field of the house: the Taylor and Runge-Kutta kernels take it with float
    coefficients; the rigorous flow (refimpl/_rigorous_flow.py) builds the same tables
    (:func:`body_field_tables`) with Arb ball coefficients for its enclosures."""

    d: int
    lin: tuple
    quad: tuple

    def monomials(self) -> list[tuple[int, int]]:
        return sorted({ij for q in self.quad for ij in q})

    def constant_components(self) -> set[int]:
        """Components whose field is identically zero (constant along every solution)."""
        return {c for c in range(self.d) if not self.lin[c] and not self.quad[c]}

    def __call__(self, y):
        """Evaluate the field at ``y`` (sequence of numbers or arrays): a list of ``d`` values."""
        out = []
        for c in range(self.d):
            v = 0.0 * y[0]
            for (i, j), q in self.quad[c].items():
                v = v + q * y[i] * y[j]
            for i, q in self.lin[c].items():
                v = v + q * y[i]
            out.append(v)
        return out


def _is_zero(v) -> bool:
    """Exactly zero: ``v.is_zero()`` for Arb balls (a ball that merely contains 0 is kept), else ``v == 0``."""
    z = getattr(v, "is_zero", None)
    return bool(z()) if callable(z) else v == 0


def body_field_tables(n: int, fI, TI=None, fL=None, IF=None) -> tuple[int, tuple, tuple]:
    """``(d, lin, quad)`` of the body field (``Upsilon = 0``) from its contractions, in any number
    type: floats here, Arb balls in refimpl/_rigorous_flow.py -- the one definition of which
    coefficient multiplies which monomial (``n = dim g``, ``Gamma`` at indices ``n..2n-1``):

    * ``pidot_a``: ``-fI[m, a, c]`` on ``pi_m pi_c``; ``TI[a, c]`` on ``pi_c``; ``fL[a, m]`` on ``Gamma_m``;
    * ``Gammadot_mu``: ``IF[mu, c, a]`` on ``pi_c Gamma_a``;

    with ``fI[m, a, c] = sum_b f^m_ab (I^-1)_bc``, ``TI = Theta I^-1`` (None for ``Theta = 0``),
    ``fL[a, m] = sum_c f^m_ac L^c`` and ``IF[mu, c, a] = sum_b (I^-1)_bc f^a_{b mu}`` (both None
    without gravity). Keys ``(i, j)`` with ``i <= j``; equal monomials summed in the loops' order,
    exact zeros dropped (:func:`_is_zero`).
    """
    gravity = fL is not None
    d = 2 * n if gravity else n
    lin: list[dict] = [{} for _ in range(d)]
    quad: list[dict] = [{} for _ in range(d)]

    def add(table, key, v):
        if not _is_zero(v):
            table[key] = table[key] + v if key in table else v

    for a in range(n):
        for m in range(n):
            for c in range(n):
                add(quad[a], (min(m, c), max(m, c)), -fI[m, a, c])
    if TI is not None:
        for a in range(n):
            for c in range(n):
                add(lin[a], c, TI[a, c])
    if gravity:
        for a in range(n):
            for m in range(n):
                add(lin[a], n + m, fL[a, m])
        for mu in range(n):
            for c in range(n):
                for a in range(n):
                    add(quad[n + mu], (c, n + a), IF[mu, c, a])
    lin_t = tuple({k: v for k, v in t.items() if not _is_zero(v)} for t in lin)
    quad_t = tuple({k: v for k, v in t.items() if not _is_zero(v)} for t in quad)
    return d, lin_t, quad_t


def quadratic_field(model) -> QuadraticField:
    """The body field of a :class:`refimpl.model.Model` with ``Upsilon = 0`` as a quadratic polynomial
    (float coefficients; the monomials and their coefficients: :func:`body_field_tables`)."""
    if not model.upsilon_zero:
        raise ValueError(
            "quadratic_field: the body field is a polynomial only for Upsilon = 0 (Phi = 1, vier6)"
        )
    n, f, Ii = model.n, model.f, model.Iinv
    fI = np.einsum("mab,bc->mac", f, Ii)  # f^m_ab (I^-1)_bc
    TI = None if model.theta_zero else model.theta @ Ii
    fL = IF = None
    if model.gravity:
        fL = np.einsum("mac,c->am", f, model.Lvec)  # sum_c f^m_ac L^c
        IF = np.einsum("bc,abu->uca", Ii, f)  # sum_b (I^-1)_bc f^a_{b mu}
    d, lin, quad = body_field_tables(n, fI, TI, fL, IF)
    return QuadraticField(
        d,
        tuple({k: float(v) for k, v in t.items()} for t in lin),
        tuple({k: float(v) for k, v in t.items()} for t in quad),
    )


def quadratic_field_su2_full(model) -> QuadraticField:
    """The su(2) body field extended by the group element as a unit quaternion: still quadratic.

    State ``y = (pi, [Gamma,] q)`` with ``g = q_0 - i q.sigma`` (the matrix of ``exp(x^a E_a)``,
    ``E_a = -(i/2) sigma_a``; :func:`refimpl.flows.qmul` is the matching Hamilton product). The
    left-trivialised kinematics ``g^-1 dg/dt = Omega^a E_a`` (``Omega = I^-1 pi`` for ``Upsilon = 0``,
    vier10) read ``dq/dt = q * (0, Omega/2)``::

        dq_0/dt = -1/2 q.Omega,        dq/dt = 1/2 (q_0 Omega + q x Omega),

    bilinear in ``(q, pi)``. ``Gamma`` is integrated by twee17 (sign-corrected) alongside, so the body
    block is exactly :func:`quadratic_field`; ``Gamma = Ad(g)^T gamma`` holds along the exact flow.
    """
    if not model.su2:
        raise ValueError(
            "quadratic_field_su2_full: the quaternion kinematics are written for su(2)/so(3)"
        )
    B = quadratic_field(model)
    n, Ii = 3, model.Iinv
    d = B.d + 4
    q0 = B.d
    lin = [dict(t) for t in B.lin] + [{} for _ in range(4)]
    quad = [dict(t) for t in B.quad] + [{} for _ in range(4)]

    def add(c, i, j, v):
        if v != 0:
            key = (min(i, j), max(i, j))
            quad[c][key] = quad[c].get(key, 0.0) + float(v)

    eps = {(0, 1, 2): 1, (1, 2, 0): 1, (2, 0, 1): 1, (0, 2, 1): -1, (2, 1, 0): -1, (1, 0, 2): -1}
    for c in range(n):  # Omega_b = sum_c Ii[b, c] pi_c
        for b in range(n):
            add(q0, q0 + 1 + b, c, -0.5 * Ii[b, c])  # -1/2 q_b Omega_b
            add(q0 + 1 + b, q0, c, 0.5 * Ii[b, c])  # 1/2 q_0 Omega_b
            for a in range(n):
                for e in range(n):  # (q x Omega)_a = eps_aeb q_e Omega_b
                    sgn = eps.get((a, e, b), 0)
                    if sgn:
                        add(q0 + 1 + a, q0 + 1 + e, c, 0.5 * sgn * Ii[b, c])
    lin = tuple({k: v for k, v in t.items() if v != 0} for t in lin)
    quad = tuple({k: v for k, v in t.items() if v != 0} for t in quad)
    return QuadraticField(d, lin, quad)


def _key(model, order, kind):
    return (
        kind,
        order,
        model.f.tobytes(),
        model.theta.tobytes(),
        model.Iinv.tobytes(),
        None if not model.gravity else (model.Lvec.tobytes(), model.gamma.tobytes()),
    )


_CACHE = LRU(64)  # generated Taylor kernels, keyed on the numbers and the order


def scalar_taylor_integrator(model, order: int):
    """``run(y0: list, h, nsteps, observe=None) -> list``: ``nsteps`` Taylor steps of order ``order``.

    ``observe(k, y)`` (optional) is called after step ``k`` with the state as a list.
    Works for float and for ``mpmath.mpf`` inputs (``h`` and ``y0`` of the same type).
    """
    order = _check_order(order)
    F = model.quadratic_field
    return _CACHE.get(_key(model, order, "scalar"), lambda: codegen.scalar_taylor(F, order))


def _check_order(order) -> int:
    if not isinstance(order, (int, np.integer)) or isinstance(order, bool) or order < 1:
        raise ValueError(f"Taylor order must be an int >= 1, got {order!r}")
    return int(order)


def numpy_taylor_integrator(model, order: int):
    """``run(y0 (d, N) array, h, nsteps, observe=None) -> (d, N) array``: the batched Taylor method.

    Same recurrence as :func:`scalar_taylor_integrator` on rows of ``N`` trajectories: the
    coefficients are one array ``Y`` of shape ``(P + 1, d, N)``; for each order ``k`` each monomial's
    Cauchy product ``sum_a Y_{a,i} Y_{k-a,j}`` is one ``einsum('an,an->n')`` over strided views
    (no copies), a constant factor (identically zero field) contributes its ``a = 0`` term only,
    and ``y(t + h) = sum_k Y_k`` is one matrix-vector product. ``observe(k, y)`` is called after
    step ``k``; trajectories are processed in chunks of ``chunk``.
    """
    order = _check_order(order)
    F = model.quadratic_field
    return _CACHE.get(_key(model, order, "numpy"), lambda: _numpy_run(F, order))


def _numpy_run(F, P: int):
    d = F.d
    rows = len(F.monomials())
    kernel = codegen.numpy_taylor_step(F, P)

    def run(y0, h, nsteps: int, observe=None, chunk: int = CHUNK):
        y = np.array(y0, dtype=float)
        if y.ndim != 2 or y.shape[0] != d:
            raise ValueError(f"y0 must have shape ({d}, N), got {y.shape}")
        N = y.shape[1]
        work = []
        for lo in range(0, N, chunk):
            m = min(chunk, N - lo)
            Y = np.zeros((P + 1, d, m))
            Y[0] = y[:, lo : lo + m]
            work.append(
                (Y, np.empty((max(rows, 1), m)), np.empty(m), np.ones(P + 1), np.empty(d * m))
            )
        for step in range(nsteps):
            for Y, pr, tmp, ones, flat in work:
                kernel(Y, pr, tmp, ones, flat, h)
            if observe is not None:
                observe(step + 1, np.concatenate([w[0][0] for w in work], axis=1))
        return np.concatenate([w[0][0] for w in work], axis=1) if work else y

    run.source = codegen.scalar.numpy_taylor_step_source(F, P)
    return run
