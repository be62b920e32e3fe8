"""Lie algebra cohomology with trivial real coefficients in degrees 1 and 2.

* ``delta_1``: ``C^1 = g* -> C^2``, ``(delta_1 xi)_ab = -xi_m f^m_ab`` (zeven3).
* ``delta_2``: ``C^2 -> C^3`` (zeven1):
  ``(delta_2 Theta)_abc = -Theta_kc f^k_ab + Theta_kb f^k_ac - Theta_ka f^k_bc``.
* ``Z^2 = ker delta_2`` on antisymmetric Theta, ``B^2 = im delta_1``,
  ``dim H^2 = dim Z^2 - dim B^2``; note ``dim B^2 = dim [g, g]``.

Everything is exact (sympy) when the algebra has exact structure constants
and floating (SVD with a stated rank tolerance) otherwise.

A 2-cochain is stored as an antisymmetric ``(n, n)`` matrix; coordinates on
``C^2`` are its entries ``Theta_ab``, ``a < b`` (``pair_index``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy

from ._algebra import EPS, LieAlgebra, to_exact

__all__ = [
    "delta1",
    "delta2",
    "cocycle_basis",
    "coboundary_basis",
    "h2_dim",
    "cohomology",
    "cocycle_residual",
    "check_cocycle",
    "solve_coboundary",
    "Cohomology",
]


def pair_index(n: int) -> list[tuple[int, int]]:
    return [(a, b) for a in range(n) for b in range(a + 1, n)]


def delta1(alg: LieAlgebra, xi: Any, exact: bool = False) -> np.ndarray:
    """``(delta_1 xi)_ab = -xi_m f^m_ab``: the coboundary Theta of zeven3.

    >>> from tstarg.refimpl import su2
    >>> float(delta1(su2(), [0, 0, 1])[0, 1])  # -xi_3 eps_312
    -1.0
    """
    if exact:
        alg._need_exact("delta1(exact=True)")
        xe = np.array([to_exact(v) for v in xi], dtype=object)
        return np.vectorize(sympy.simplify, otypes=[object])(
            -np.einsum("m,mab->ab", xe, alg.f_exact)
        )
    return -np.einsum("m,mab->ab", np.asarray(xi, dtype=float), alg.f)


def delta2(alg: LieAlgebra, theta: Any, exact: bool = False) -> np.ndarray:
    """``(delta_2 Theta)_abc`` of zeven1, shape ``(n, n, n)``."""
    if exact:
        alg._need_exact("delta2(exact=True)")
        t = np.vectorize(to_exact, otypes=[object])(np.asarray(theta, dtype=object))
        f = alg.f_exact
    else:
        t = np.asarray(theta, dtype=float)
        f = alg.f
    out = (
        -np.einsum("kc,kab->abc", t, f)
        + np.einsum("kb,kac->abc", t, f)
        - np.einsum("ka,kbc->abc", t, f)
    )
    if exact:
        out = np.vectorize(lambda v: sympy.simplify(sympy.expand(v)), otypes=[object])(out)
    return out


def _delta2_matrix(alg: LieAlgebra, exact: bool):
    """Matrix of delta_2 on the coordinates ``Theta_ab, a < b``; rows: all (a, b, c)."""
    n = alg.dim
    pairs = pair_index(n)
    cols = []
    for a, b in pairs:
        t = np.zeros((n, n), dtype=object if exact else float)
        if exact:
            t[:, :] = sympy.Integer(0)
            t[a, b], t[b, a] = sympy.Integer(1), sympy.Integer(-1)
        else:
            t[a, b], t[b, a] = 1.0, -1.0
        cols.append(delta2(alg, t, exact=exact).reshape(-1))
    if exact:
        return (
            sympy.Matrix(np.array(cols, dtype=object).T.tolist()) if pairs else sympy.zeros(n**3, 0)
        )
    return np.array(cols).T if pairs else np.zeros((n**3, 0))


def _unpack(alg: LieAlgebra, vec, exact: bool) -> np.ndarray:
    n = alg.dim
    if exact:
        t = np.full((n, n), sympy.Integer(0), dtype=object)
    else:
        t = np.zeros((n, n))
    for (a, b), v in zip(pair_index(n), vec):
        t[a, b] = v
        t[b, a] = -v
    return t


def _float_nullspace(m: np.ndarray, scale: float) -> np.ndarray:
    if m.shape[1] == 0:
        return np.zeros((0, 0))
    u, s, vt = np.linalg.svd(m)
    # Rank tolerance: singular values below 64 * max(dims) * eps * scale are zero.
    tol = 64 * max(m.shape) * EPS * max(scale, 1.0)
    rank = int(np.sum(s > tol))
    return vt[rank:].T


_COCYCLE_CACHE: dict = {}
_COCYCLE_CACHE_SIZE = 256


def cocycle_basis(alg: LieAlgebra, exact: bool | None = None) -> list[np.ndarray]:
    """A basis of ``Z^2``: antisymmetric ``(n, n)`` matrices with ``delta_2 Theta = 0``.

    Cached on the structure constants (their float bytes, and their exact values where the
    algebra is exact): Hypothesis draws cocycles of the same algebra many times, and the exact
    nullspace of su(3)'s 28 x 56 system takes seconds. Each call returns fresh copies."""
    exact = alg.is_exact if exact is None else exact
    key = (
        exact,
        alg.f.shape,
        alg.f.tobytes(),
        str(alg.f_exact.tolist()) if alg.is_exact else None,
    )
    hit = _COCYCLE_CACHE.get(key)
    if hit is None:
        m = _delta2_matrix(alg, exact)
        if exact:
            hit = [_unpack(alg, list(v), True) for v in m.nullspace(simplify=True)]
        else:
            ns = _float_nullspace(m, float(np.max(np.abs(alg.f))) if alg.f.size else 1.0)
            hit = [_unpack(alg, ns[:, i], False) for i in range(ns.shape[1])]
        if len(_COCYCLE_CACHE) >= _COCYCLE_CACHE_SIZE:
            _COCYCLE_CACHE.pop(next(iter(_COCYCLE_CACHE)))
        _COCYCLE_CACHE[key] = hit
    return [b.copy() for b in hit]


def coboundary_basis(alg: LieAlgebra, exact: bool | None = None) -> list[np.ndarray]:
    """A basis of ``B^2 = delta_1(g*)``."""
    exact = alg.is_exact if exact is None else exact
    n = alg.dim
    cols = [delta1(alg, np.eye(n, dtype=int)[m].tolist(), exact=exact) for m in range(n)]
    if exact:
        mat = (
            sympy.Matrix([[c[a, b] for c in cols] for a, b in pair_index(n)])
            if n > 1
            else sympy.zeros(0, n)
        )
        basis = mat.columnspace(simplify=True) if mat.rows else []
        return [_unpack(alg, list(v), True) for v in basis]
    mat = (
        np.array([[c[a, b] for c in cols] for a, b in pair_index(n)]) if n > 1 else np.zeros((0, n))
    )
    if mat.size == 0:
        return []
    u, s, vt = np.linalg.svd(mat)
    rank = int(np.sum(s > 64 * max(mat.shape) * EPS * max(1.0, s[0])))
    return [_unpack(alg, u[:, i], False) for i in range(rank)]


@dataclass(frozen=True)
class Cohomology:
    dim_z2: int
    dim_b2: int
    exact: bool

    @property
    def dim_h2(self) -> int:
        return self.dim_z2 - self.dim_b2


def cohomology(alg: LieAlgebra, exact: bool | None = None) -> Cohomology:
    """Dimensions of ``Z^2``, ``B^2`` and ``H^2`` (exact when the algebra is)."""
    exact = alg.is_exact if exact is None else exact
    return Cohomology(
        dim_z2=len(cocycle_basis(alg, exact)),
        dim_b2=len(coboundary_basis(alg, exact)),
        exact=exact,
    )


def h2_dim(alg: LieAlgebra, exact: bool | None = None) -> int:
    """``dim H^2 = dim Z^2 - dim B^2`` (zeven3).

    >>> from tstarg.refimpl import abelian, heisenberg, su2
    >>> h2_dim(su2()), h2_dim(heisenberg()), h2_dim(abelian(3))  # Whitehead; h(3); Lambda^2 R^3
    (0, 2, 3)
    """
    return cohomology(alg, exact).dim_h2


def cocycle_residual(alg: LieAlgebra, theta: Any) -> float:
    """``max |delta_2 Theta|`` in float64."""
    return float(np.max(np.abs(delta2(alg, theta)))) if alg.dim else 0.0


def check_cocycle(alg: LieAlgebra, theta: Any, *, name: str = "Theta") -> None:
    """Raise ``ValueError`` unless ``theta`` is an antisymmetric 2-cocycle (zeven1).

    Exact check when both the algebra and ``theta`` are exact; otherwise the
    float64 error model: each entry of delta_2 Theta sums ``3n`` products, so
    ``|residual| <= 3 n eps max|f| max|Theta|`` (x8 slack).
    """
    t_obj = np.asarray(theta, dtype=object)
    n = alg.dim
    if t_obj.shape != (n, n):
        raise ValueError(f"{name} must have shape ({n}, {n}) for {alg.name}, got {t_obj.shape}")
    t = np.array(t_obj, dtype=float)
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{name} contains NaN or infinity")
    exact = alg.is_exact and all(not isinstance(v, (float, np.floating)) for v in t_obj.flat)
    if exact:
        te = np.vectorize(to_exact, otypes=[object])(t_obj)
        asym = te + te.T
        if any(v != 0 for v in asym.flat):
            raise ValueError(
                f"{name} is not antisymmetric: max |{name} + {name}^T| = {np.max(np.abs(t + t.T)):.3g}"
            )
        res = delta2(alg, te, exact=True)
        if any(v != 0 for v in res.flat):
            worst = float(np.max(np.abs(np.array(res, dtype=float))))
            raise ValueError(
                f"{name} is not a 2-cocycle of {alg.name} (zeven1): exact residual max |delta_2 {name}| = {worst:.3g}"
            )
        return
    if np.any(t + t.T != 0):
        raise ValueError(
            f"{name} is not antisymmetric: max |{name} + {name}^T| = {np.max(np.abs(t + t.T)):.3g}"
        )
    res = cocycle_residual(alg, t)
    tol = 24 * n * EPS * max(1.0, float(np.max(np.abs(alg.f)))) * max(1.0, float(np.max(np.abs(t))))
    if res > tol:
        raise ValueError(
            f"{name} is not a 2-cocycle of {alg.name} (zeven1): max |delta_2 {name}| = {res:.3g} "
            f"> tolerance 24 n eps max|f| max|{name}| = {tol:.3g}"
        )


def solve_coboundary(alg: LieAlgebra, theta: Any, exact: bool | None = None) -> np.ndarray:
    """The ``xi`` with ``Theta_ab = -xi_m f^m_ab`` (zeven3).

    Raises ``ValueError`` with the cocycle residual when ``theta`` is not a
    cocycle, and with the least-squares residual when it is a cocycle whose
    class in ``H^2`` is not zero (no xi exists; never for semisimple algebras,
    by Whitehead's lemma). ``xi`` is unique up to the annihilator of ``[g, g]``
    (zero for semisimple algebras); the minimum-norm solution is returned.
    """
    check_cocycle(alg, theta)
    n = alg.dim
    t_obj = np.asarray(theta, dtype=object)
    if exact is None:
        exact = alg.is_exact and all(not isinstance(v, (float, np.floating)) for v in t_obj.flat)
    pairs = pair_index(n)
    if exact:
        a_mat = sympy.Matrix([[-alg.f_exact[m, a, b] for m in range(n)] for a, b in pairs])
        rhs = sympy.Matrix([to_exact(t_obj[a, b]) for a, b in pairs])
        try:
            sol, params = a_mat.gauss_jordan_solve(rhs)
        except ValueError:
            raise ValueError(
                f"Theta is a cocycle of {alg.name} but not a coboundary: no xi with Theta = -xi.f (zeven3); "
                f"its class in H^2 is non-zero"
            ) from None
        sol = sol.subs({p: 0 for p in params})
        return np.array([sympy.simplify(v) for v in sol], dtype=object)
    a_mat = np.array([[-alg.f[m, a, b] for m in range(n)] for a, b in pairs])
    rhs = np.array([float(t_obj[a, b]) for a, b in pairs])
    xi, *_ = np.linalg.lstsq(a_mat, rhs, rcond=None)
    res = float(np.max(np.abs(a_mat @ xi - rhs))) if pairs else 0.0
    # Error model: least squares on a system with condition number kappa.
    s = np.linalg.svd(a_mat, compute_uv=False) if pairs else np.ones(1)
    s_nz = s[s > 64 * max(a_mat.shape) * EPS * max(1.0, s[0])]
    kappa = float(s_nz[0] / s_nz[-1]) if s_nz.size else 1.0
    tol = 32 * n * EPS * kappa * max(1.0, float(np.max(np.abs(rhs))) if rhs.size else 1.0)
    if res > tol:
        raise ValueError(
            f"Theta is a cocycle of {alg.name} but not a coboundary: no xi with Theta = -xi.f (zeven3); "
            f"least-squares residual {res:.3g} > {tol:.3g}"
        )
    return xi
