"""Validated real Lie algebras given by structure constants.

Conventions (docs/conventions.md): basis ``e_a`` with indices ``0..n-1``;
``f[m, a, b] = f^m_ab`` with ``[e_a, e_b] = f^m_ab e_m``;
``ad_x[m, b] = x^a f[m, a, b]``; Killing form ``K_ab = f^m_an f^n_bm``.

An algebra keeps two copies of its structure constants:

* ``f``: float64, what the fast implementation uses;
* ``f_exact``: an object array of sympy numbers (rationals, or algebraic
  numbers such as ``sqrt(3)/2``) when the constants are known exactly, else
  ``None``. The mpmath reference evaluates these at any precision, and the
  cohomology is then computed exactly.

Construction checks antisymmetry ``f^m_ab = -f^m_ba`` and the Jacobi identity
``f^m_ak f^k_bc + f^m_bk f^k_ca + f^m_ck f^k_ab = 0``; a violation raises
``ValueError`` with the worst residual and where it occurs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Sequence

import numpy as np
import sympy

from ._validate import (  # the boundary and the one number parser (issue 30)
    EPS,
    check_dimension,
    check_jacobi,
    exact_sympy,
    parse_number,
)

__all__ = ["LieAlgebra", "to_exact", "jacobi_residual"]


def to_exact(value: Any) -> sympy.Expr:
    """Convert an int, Fraction, decimal string, float or sympy number to sympy, exactly.

    Floats are converted to the binary rational they denote (no rounding).
    """
    if isinstance(value, sympy.Basic):
        return value
    if isinstance(value, bool):
        raise TypeError("booleans are not numbers here")
    if isinstance(value, (int, np.integer)):
        return sympy.Integer(int(value))
    if isinstance(value, Fraction):
        return sympy.Rational(value.numerator, value.denominator)
    if isinstance(value, str):
        q = parse_number(value)
        return sympy.Rational(q.numerator, q.denominator)
    if isinstance(value, (float, np.floating)):
        if not np.isfinite(value):
            raise ValueError(f"non-finite number {value!r}")
        return sympy.Rational(*float(value).as_integer_ratio())
    raise TypeError(f"cannot convert {type(value).__name__} {value!r} to an exact number")


def _exact_array(values: Any) -> np.ndarray:
    arr = np.asarray(values, dtype=object)
    out = np.empty(arr.shape, dtype=object)
    for idx, v in np.ndenumerate(arr):
        out[idx] = to_exact(v)
    return out


def jacobi_residual(f: np.ndarray) -> np.ndarray:
    """``J[m, a, b, c] = f^m_ak f^k_bc + f^m_bk f^k_ca + f^m_ck f^k_ab`` (object or float).

    >>> from tstarg.refimpl import su2
    >>> f = su2().f
    >>> float(abs(jacobi_residual(f)).max())  # a Lie algebra: zero
    0.0
    >>> g = np.zeros((3, 3, 3))  # [e_1, e_2] = e_3, [e_1, e_3] = e_1: not a Lie algebra, since
    >>> g[2, 0, 1], g[2, 1, 0], g[0, 0, 2], g[0, 2, 0] = 1, -1, 1, -1
    >>> float(jacobi_residual(g)[2, 0, 1, 2])  # [e_2, [e_3, e_1]] = [e_2, -e_1] = e_3, rest 0
    1.0
    """
    t = np.einsum("mak,kbc->mabc", f, f)
    return t + t.transpose(0, 2, 3, 1) + t.transpose(0, 3, 1, 2)


def _worst(arr: np.ndarray) -> tuple[float, tuple[int, ...]]:
    mags = np.abs(np.asarray(arr, dtype=float))
    idx = np.unravel_index(int(np.argmax(mags)), mags.shape)
    return float(mags[idx]), tuple(int(i) for i in idx)


@dataclass(frozen=True, eq=False)
class LieAlgebra:
    """A real Lie algebra, validated on construction.

    Parameters
    ----------
    f:
        Structure constants, shape ``(n, n, n)``, ``f[m, a, b] = f^m_ab``.
        Numbers may be floats, ints, ``Fraction``, decimal strings or sympy
        numbers; non-float entries make the algebra exact.
    name:
        A label used in reports and error messages.
    rep:
        Optional faithful matrix representation: ``rep[a]`` is the matrix of
        ``e_a`` (complex or real, numpy), satisfying
        ``[rep[a], rep[b]] = f^m_ab rep[m]`` (checked).
    rep_exact:
        Optional exact version of ``rep`` (sympy matrices), used at high
        precision.
    """

    f: np.ndarray
    name: str = "g"
    f_exact: np.ndarray | None = None
    rep: np.ndarray | None = None
    rep_exact: tuple | None = field(default=None, repr=False)
    tags: frozenset = frozenset()

    # ------------------------------------------------------------------ build
    @classmethod
    def from_structure_constants(
        cls,
        f: Any,
        *,
        name: str = "g",
        rep: Any = None,
        rep_exact: Sequence[sympy.Matrix] | None = None,
        tags: Sequence[str] = (),
        exact: bool | None = None,
    ) -> "LieAlgebra":
        """Build and validate an algebra.

        ``exact=None`` (default) keeps the exact constants when every entry is
        an exact number (int, Fraction, string, sympy); floats make the
        algebra floating unless ``exact=True``.
        """
        arr = np.asarray(f, dtype=object)
        if arr.ndim != 3 or not (arr.shape[0] == arr.shape[1] == arr.shape[2]):
            raise ValueError(f"structure constants f must have shape (n, n, n), got {arr.shape}")

        check_dimension(arr.shape[0], exact=exact is not False, what=f"{name}: structure constants")
        all_exact = all(not isinstance(v, (float, np.floating)) for v in arr.flat)
        if exact is None:
            exact = all_exact
        f_exact = _exact_array(arr) if exact else None
        if f_exact is not None:
            f_float = np.array([float(sympy.N(v, 30)) for v in f_exact.flat]).reshape(arr.shape)
        else:
            f_float = np.array(arr, dtype=float)
        if not np.all(np.isfinite(f_float)):
            bad = np.argwhere(~np.isfinite(f_float))[0]
            raise ValueError(f"structure constants f contain NaN or infinity at f{tuple(bad)}")
        rep_arr = None if rep is None else np.asarray(rep)
        alg = cls(
            f=f_float,
            name=name,
            f_exact=f_exact,
            rep=rep_arr,
            rep_exact=None if rep_exact is None else tuple(rep_exact),
            tags=frozenset(tags),
        )
        alg._validate()
        return alg

    @classmethod
    def from_matrix_basis(
        cls, basis: Sequence[sympy.Matrix], *, name: str, tags: Sequence[str] = ()
    ) -> "LieAlgebra":
        """Structure constants of the span of exact matrices ``basis``.

        Solves ``[E_a, E_b] = f^m_ab E_m`` exactly; raises if the span is not
        closed under the commutator or the matrices are dependent.
        """

        basis = list(basis)
        check_dimension(len(basis), exact=True, what=f"{name}: matrix basis")
        mats = [
            sympy.Matrix(b)
            if isinstance(b, sympy.MatrixBase)
            else sympy.Matrix([[exact_sympy(v, f"{name}: basis entry") for v in row] for row in b])
            for b in basis
        ]
        n = len(mats)
        cols = sympy.Matrix.hstack(*[m.reshape(m.rows * m.cols, 1) for m in mats])
        if cols.rank() != n:
            raise ValueError(f"{name}: the {n} basis matrices are linearly dependent")
        f = np.empty((n, n, n), dtype=object)
        pinv = (cols.T * cols).inv() * cols.T
        for a in range(n):
            for b in range(n):
                c = mats[a] * mats[b] - mats[b] * mats[a]
                vec = c.reshape(c.rows * c.cols, 1)
                coef = sympy.simplify(pinv * vec)
                if sympy.simplify(cols * coef - vec) != sympy.zeros(vec.rows, 1):
                    raise ValueError(f"{name}: [E_{a}, E_{b}] is not in the span of the basis")
                for m in range(n):
                    f[m, a, b] = sympy.nsimplify(coef[m]) if coef[m].is_number else coef[m]
        rep = np.array([np.array(m.evalf(20).tolist(), dtype=complex) for m in mats])
        if np.all(np.abs(rep.imag) == 0):
            rep = rep.real.copy()
        return cls.from_structure_constants(f, name=name, rep=rep, rep_exact=mats, tags=tags)

    def _validate(self) -> None:
        n = self.dim
        f = self.f

        check_dimension(n, exact=self.f_exact is not None, what=f"{self.name}: structure constants")
        if self.f_exact is not None:
            asym = self.f_exact + self.f_exact.transpose(0, 2, 1)
            asym = np.vectorize(lambda v: sympy.simplify(v), otypes=[object])(asym) if n else asym
            if any(v != 0 for v in asym.flat):
                worst, idx = _worst(np.vectorize(lambda v: float(sympy.N(v)), otypes=[float])(asym))
                raise ValueError(
                    f"{self.name}: structure constants are not antisymmetric in (a, b): "
                    f"|f[m,a,b] + f[m,b,a]| = {worst:.3g} at (m, a, b) = {idx}"
                )
            jac = jacobi_residual(self.f_exact) if n else np.zeros((0,))
            jac = (
                np.vectorize(lambda v: sympy.simplify(sympy.expand(v)), otypes=[object])(jac)
                if n
                else jac
            )
            if any(v != 0 for v in jac.flat):
                worst, idx = _worst(np.vectorize(lambda v: float(sympy.N(v)), otypes=[float])(jac))
                raise ValueError(
                    f"{self.name}: structure constants break the Jacobi identity exactly: "
                    f"worst residual {worst:.3g} at (m, a, b, c) = {idx}"
                )
        else:
            asym = f + f.transpose(0, 2, 1)
            # Antisymmetry is a statement about stored numbers: it holds exactly.
            if np.any(asym != 0):
                worst, idx = _worst(asym)
                raise ValueError(
                    f"{self.name}: structure constants are not antisymmetric in (a, b): "
                    f"|f[m,a,b] + f[m,b,a]| = {worst:.3g} at (m, a, b) = {idx}"
                )

            # Error model: each Jacobi entry is a sum of 3n products of size
            # <= scale^2, each rounded once: |err| <= 3 n eps scale^2 (x4 slack).
            check_jacobi(f, f"{self.name}: structure constants")
        if self.rep is not None:
            self._check_rep()

    def _check_rep(self) -> None:
        rep = np.asarray(self.rep)
        n = self.dim
        if rep.ndim != 3 or rep.shape[0] != n or rep.shape[1] != rep.shape[2]:
            raise ValueError(
                f"{self.name}: rep must have shape (n, d, d) with n = {n}, got {rep.shape}"
            )
        comm = np.einsum("aij,bjk->abik", rep, rep) - np.einsum("bij,ajk->abik", rep, rep)
        rhs = np.einsum("mab,mij->abij", self.f, rep)
        scale = max(1.0, float(np.max(np.abs(rep)))) ** 2 * max(1.0, float(np.max(np.abs(self.f))))
        err = float(np.max(np.abs(comm - rhs))) if comm.size else 0.0
        tol = 16 * rep.shape[1] * n * EPS * scale
        if err > tol:
            raise ValueError(
                f"{self.name}: rep is not a representation: max |[E_a,E_b] - f^m_ab E_m| = {err:.3g} "
                f"(tolerance {tol:.3g})"
            )
        flat = rep.reshape(n, -1)
        if n and np.linalg.matrix_rank(np.concatenate([flat.real, flat.imag], axis=1)) != n:
            raise ValueError(f"{self.name}: rep is not faithful (its matrices are dependent)")

    # ------------------------------------------------------------- properties
    @property
    def dim(self) -> int:
        return int(self.f.shape[0])

    @property
    def is_exact(self) -> bool:
        return self.f_exact is not None

    @property
    def is_rational(self) -> bool:
        return self.f_exact is not None and all(v.is_Rational for v in self.f_exact.flat)

    def ad(self, x: Any) -> np.ndarray:
        """``ad_x[m, b] = x^a f[m, a, b]``; ``x`` may carry leading batch axes."""
        return np.einsum("...a,mab->...mb", np.asarray(x, dtype=float), self.f)

    def killing(self, exact: bool = False) -> np.ndarray | sympy.Matrix:
        """Killing form ``K_ab = f^m_an f^n_bm = tr(ad_a ad_b)``."""
        if exact:
            self._need_exact("killing(exact=True)")
            k = np.einsum("man,nbm->ab", self.f_exact, self.f_exact)
            return sympy.Matrix(k.tolist()).applyfunc(sympy.simplify)
        return np.einsum("man,nbm->ab", self.f, self.f)

    def is_semisimple(self) -> bool:
        """Cartan's criterion: semisimple iff the Killing form is non-degenerate.

        Exact (sympy determinant) when the constants are exact; otherwise the
        smallest singular value of K is compared with ``n eps ||K||``.
        """
        if self.dim == 0:
            return False
        if self.is_exact:
            return sympy.simplify(self.killing(exact=True).det()) != 0
        k = self.killing()
        s = np.linalg.svd(k, compute_uv=False)
        return bool(s[-1] > 64 * self.dim * EPS * max(s[0], 1.0))

    def derived_dim(self) -> int:
        """``dim [g, g]``: the rank of the map ``(a, b) -> f[:, a, b]``."""
        if self.is_exact:
            return sympy.Matrix(self.f_exact.reshape(self.dim, -1).tolist()).rank(simplify=True)
        return int(np.linalg.matrix_rank(self.f.reshape(self.dim, -1)))

    def is_unimodular(self) -> bool:
        """``tr ad_x = 0`` for every x, i.e. ``f^m_am = 0``."""
        tr = np.einsum("mam->a", self.f)
        return bool(np.all(np.abs(tr) <= 8 * self.dim * EPS * max(1.0, np.max(np.abs(self.f)))))

    def _need_exact(self, what: str) -> None:
        if not self.is_exact:
            raise ValueError(f"{self.name}: {what} needs exact structure constants")

    # ---------------------------------------------------------- constructions
    def change_basis(self, c: Any, *, name: str | None = None) -> "LieAlgebra":
        """The same algebra in the basis ``e'_a = C^b_a e_b`` (columns of ``C``).

        ``f'[k, a, b] = (C^-1)[k, m] f[m, c, d] C[c, a] C[d, b]``; the
        representation transforms as ``E'_a = C^b_a E_b``.
        """
        n = self.dim
        c_obj = np.asarray(c, dtype=object)
        if c_obj.shape != (n, n):
            raise ValueError(f"change of basis C must have shape ({n}, {n}), got {c_obj.shape}")
        exact_c = all(not isinstance(v, (float, np.floating)) for v in c_obj.flat)
        label = name or f"{self.name}[basis changed]"
        rep = (
            None
            if self.rep is None
            else np.einsum("ba,bij->aij", np.array(c_obj, dtype=float), self.rep)
        )
        if self.is_exact and exact_c:
            cm = sympy.Matrix(_exact_array(c_obj).tolist())
            if cm.det() == 0:
                raise ValueError("change of basis C is singular")
            cinv = np.array(cm.inv().tolist(), dtype=object)
            ce = np.array(cm.tolist(), dtype=object)
            fn = np.einsum("km,mcd,ca,db->kab", cinv, self.f_exact, ce, ce)
            fn = np.vectorize(sympy.simplify, otypes=[object])(fn)
            rep_exact = None
            if self.rep_exact is not None:
                rep_exact = [
                    sum(
                        (ce[b, a] * self.rep_exact[b] for b in range(n)),
                        sympy.zeros(*self.rep_exact[0].shape),
                    )
                    for a in range(n)
                ]
            return LieAlgebra.from_structure_constants(
                fn, name=label, rep=rep, rep_exact=rep_exact, tags=self.tags - {"orthonormal"}
            )
        cf = np.array(c_obj, dtype=float)
        if not np.all(np.isfinite(cf)):
            raise ValueError("change of basis C contains NaN or infinity")
        if abs(np.linalg.det(cf)) == 0 or np.linalg.cond(cf) > 1 / (64 * EPS):
            raise ValueError(f"change of basis C is singular (cond = {np.linalg.cond(cf):.3g})")
        fn = np.einsum("km,mcd,ca,db->kab", np.linalg.inv(cf), self.f, cf, cf)
        fn = 0.5 * (fn - fn.transpose(0, 2, 1))  # exact antisymmetry of the stored numbers
        return LieAlgebra.from_structure_constants(
            fn, name=label, rep=rep, tags=self.tags - {"orthonormal"}
        )

    def direct_sum(self, other: "LieAlgebra", *, name: str | None = None) -> "LieAlgebra":
        """``g (+) h``: basis of g first, then of h; the two commute."""
        n, m = self.dim, other.dim
        label = name or f"{self.name}+{other.name}"
        if self.is_exact and other.is_exact:
            f = np.full((n + m,) * 3, sympy.Integer(0), dtype=object)
            f[:n, :n, :n] = self.f_exact
            f[n:, n:, n:] = other.f_exact
        else:
            f = np.zeros((n + m,) * 3)
            f[:n, :n, :n] = self.f
            f[n:, n:, n:] = other.f
        rep = None
        rep_exact = None
        if self.rep is not None and other.rep is not None:
            d1, d2 = self.rep.shape[1], other.rep.shape[1]
            rep = np.zeros((n + m, d1 + d2, d1 + d2), dtype=np.result_type(self.rep, other.rep))
            rep[:n, :d1, :d1] = self.rep
            rep[n:, d1:, d1:] = other.rep
            if self.rep_exact is not None and other.rep_exact is not None:
                rep_exact = [sympy.diag(r, sympy.zeros(d2, d2)) for r in self.rep_exact] + [
                    sympy.diag(sympy.zeros(d1, d1), r) for r in other.rep_exact
                ]
        tags = {"direct_sum"} | (
            {"semisimple"} if "semisimple" in self.tags and "semisimple" in other.tags else set()
        )
        return LieAlgebra.from_structure_constants(
            f, name=label, rep=rep, rep_exact=rep_exact, tags=tags
        )

    def semidirect(self, rho: Any, *, name: str | None = None) -> "LieAlgebra":
        """``g |x_rho V``: ``rho[a]`` is the (k, k) matrix of ``e_a`` acting on ``V = R^k``.

        Brackets: ``[e_a, e_b] = f^m_ab e_m``, ``[e_a, v_i] = rho[a][j, i] v_j``,
        ``[v_i, v_j] = 0``. ``rho`` must be a representation (checked through
        the Jacobi identity of the result). Faithful representation when
        ``rho`` is faithful: ``[[rho(u), v], [0, 0]]``.
        """
        n = self.dim
        rho_obj = np.asarray(rho, dtype=object)
        if rho_obj.ndim != 3 or rho_obj.shape[0] != n or rho_obj.shape[1] != rho_obj.shape[2]:
            raise ValueError(f"rho must have shape ({n}, k, k), got {rho_obj.shape}")
        k = rho_obj.shape[1]
        exact = self.is_exact and all(not isinstance(v, (float, np.floating)) for v in rho_obj.flat)
        if exact:
            r = _exact_array(rho_obj)
            f = np.full((n + k,) * 3, sympy.Integer(0), dtype=object)
            f[:n, :n, :n] = self.f_exact
        else:
            r = np.array(rho_obj, dtype=float)
            f = np.zeros((n + k,) * 3)
            f[:n, :n, :n] = self.f
        for a in range(n):
            for i in range(k):
                for j in range(k):
                    f[n + j, a, n + i] = r[a, j, i]
                    f[n + j, n + i, a] = -r[a, j, i]
        label = name or f"{self.name}|x R^{k}"
        rep = None
        rep_exact = None
        rf = np.array(r, dtype=float)
        if np.linalg.matrix_rank(rf.reshape(n, -1)) == n:
            rep = np.zeros((n + k, k + 1, k + 1))
            rep[:n, :k, :k] = rf
            for i in range(k):
                rep[n + i, i, k] = 1.0
            if exact:
                rep_exact = []
                for a in range(n):
                    mat = sympy.zeros(k + 1, k + 1)
                    mat[:k, :k] = sympy.Matrix(r[a].tolist())
                    rep_exact.append(mat)
                for i in range(k):
                    mat = sympy.zeros(k + 1, k + 1)
                    mat[i, k] = 1
                    rep_exact.append(mat)
        return LieAlgebra.from_structure_constants(
            f, name=label, rep=rep, rep_exact=rep_exact, tags={"semidirect"}
        )

    # ------------------------------------------------------- representations
    def ad_exact(self, x: Sequence[Any]) -> sympy.Matrix:
        self._need_exact("ad_exact")
        xe = [to_exact(v) for v in x]
        n = self.dim
        return sympy.Matrix(n, n, lambda m, b: sum(xe[a] * self.f_exact[m, a, b] for a in range(n)))

    def __repr__(self) -> str:  # pragma: no cover - cosmetic
        kind = "exact" if self.is_exact else "float"
        return f"LieAlgebra({self.name!r}, dim={self.dim}, {kind})"
