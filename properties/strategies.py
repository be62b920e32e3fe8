"""Hypothesis strategies for models and points (Hypothesis' own API style).

All strategies are shrinkable and draw their randomness from Hypothesis (no
global RNG). Exact draws use small rationals so the reference and sympy can
work exactly.

* :func:`catalogue_algebras` -- algebras of the catalogue;
* :func:`cocycles` -- random elements of ``Z^2`` (exact nullspace of delta_2);
* :func:`upsilons` -- antisymmetric ``(n, n)`` matrices;
* :func:`points` -- ``(x, pi)`` in a conditioning regime:
  ``"generic"``, ``"near_degenerate"`` (:func:`degeneracy_condition`
  ``||Phi^-1|| max(1, ||S|| ||Upsilon||)`` in ``[1e2, 1e12]``),
  ``"large_momenta"``, ``"near_chart_boundary"``.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import sympy
from hypothesis import assume, reject
from hypothesis import strategies as st

from tstarg.refimpl import (
    CATALOGUE_NAMES,
    LieAlgebra,
    abelian,
    bianchi,
    catalogue,
    coboundary_basis,
    cocycle_basis,
    delta2,
    exact_sympy,
    jacobi_residual,
)
from tstarg.refimpl.fast import implementation as _fast

__all__ = [
    "catalogue_algebras",
    "lie_algebras",
    "basis_changes",
    "FAMILIES",
    "is_solvable",
    "is_nilpotent",
    "cocycles",
    "upsilons",
    "points",
    "models",
    "scenes",
    "rationals",
    "REGIMES",
    "phi_condition",
    "jacobi_breaking_constants",
    "non_cocycles",
    "degeneracy_condition",
    "central_tolerance",
]

EPS = float(np.finfo(float).eps)

REGIMES = ("generic", "near_degenerate", "large_momenta", "near_chart_boundary")


def rationals(*, max_numerator: int = 9, denominator: int = 8) -> st.SearchStrategy[Fraction]:
    """Small rationals ``k / denominator`` with ``|k| <= max_numerator``."""
    return st.integers(-max_numerator, max_numerator).map(lambda k: Fraction(k, denominator))


# ====================================================================== algebras
# Random algebras are built with exact rational structure constants (ints and
# Fractions -> sympy Rationals), so exact checks can run on them and the
# float64 constants are correctly rounded.

FAMILIES = (
    "bianchi_class_b",
    "catalogue",
    "basis_changed",
    "solvable",
    "nilpotent",
    "semidirect",
    "direct_sum",
    "bianchi_class_a",
)
"""Families :func:`lie_algebras` draws from. Class B Bianchi algebras come first (shrinking
goes there) and are drawn as often as the catalogue: algebras that only look like so(3)
hide mistakes (the so(3) trap)."""

_WEIGHTS = {
    "bianchi_class_b": 3,
    "catalogue": 2,
    "basis_changed": 2,
    "solvable": 2,
    "nilpotent": 2,
    "semidirect": 2,
    "direct_sum": 2,
    "bianchi_class_a": 1,
}


def _check_bound(name, value, *, low=None, allow_none=True):
    if value is None and allow_none:
        return
    if not isinstance(value, int) or isinstance(value, bool):
        raise ValueError(f"{name} must be an int, got {value!r}")
    if low is not None and value < low:
        raise ValueError(f"{name} must be >= {low}, got {value}")


def _check_flag(name, value):
    if value is not None and not isinstance(value, bool):
        raise ValueError(f"{name} must be True, False or None, got {value!r}")


def _ranks_series(alg: LieAlgebra, lower: bool) -> list[int]:
    """Dimensions of the derived (``lower=False``) or lower central (``True``) series, in float64.

    The constants are small rationals, so the ranks are robust (SVD threshold
    ``64 n eps max|f|`` over a basis of entries of size >= 1/64).
    """
    n = alg.dim
    f = alg.f
    space = np.eye(n)
    dims = [n]
    for _ in range(n + 1):
        other = np.eye(n) if lower else space
        # span of [u, v] for u in space, v in other
        br = np.einsum("mab,ia,jb->ijm", f, space, other).reshape(-1, n)
        if br.size == 0 or not br.any():
            dims.append(0)
            break
        u, s, vt = np.linalg.svd(br, full_matrices=False)
        r = int(np.sum(s > 64 * n * EPS * max(1.0, s[0])))
        space = vt[:r]
        dims.append(r)
        if r == dims[-2]:
            break
    return dims


def is_solvable(alg: LieAlgebra) -> bool:
    """The derived series ``g, [g, g], ...`` reaches 0."""
    return alg.dim == 0 or _ranks_series(alg, lower=False)[-1] == 0


def is_nilpotent(alg: LieAlgebra) -> bool:
    """The lower central series ``g, [g, g], [g, [g, g]], ...`` reaches 0."""
    return alg.dim == 0 or _ranks_series(alg, lower=True)[-1] == 0


def _from_matrix_units(k: int, diag: list, positions: list, name: str, tags) -> LieAlgebra:
    """The span of diagonal matrices ``diag`` (rational k-vectors) and matrix units ``E_ij`` (i < j).

    ``positions`` must be closed (``(i, j), (j, l)`` in it => ``(i, l)`` in it), so the
    span is a subalgebra of the upper-triangular matrices; brackets are computed
    exactly: ``[D, E_ij] = (d_i - d_j) E_ij``, ``[E_ij, E_kl] = d_jk E_il - d_li E_kj``.
    """
    r = len(diag)
    n = r + len(positions)
    index = {p: r + t for t, p in enumerate(positions)}
    f = np.full((n, n, n), Fraction(0), dtype=object)
    for a, d in enumerate(diag):
        for (i, j), b in index.items():
            c = Fraction(d[i]) - Fraction(d[j])
            f[b, a, b] += c
            f[b, b, a] -= c
    for (i, j), a in index.items():
        for (k2, l2), b in index.items():
            if j == k2:
                f[index[(i, l2)], a, b] += 1
            if l2 == i:
                f[index[(k2, j)], a, b] -= 1
    rep = []
    for d in diag:
        rep.append(np.diag([float(v) for v in d]))
    for i, j in positions:
        m = np.zeros((k, k))
        m[i, j] = 1.0
        rep.append(m)
    return LieAlgebra.from_structure_constants(f, name=name, rep=np.array(rep), tags=tags)


def _close_positions(k: int, chosen) -> list:
    pos = set(chosen)
    changed = True
    while changed:
        changed = False
        for i, j in list(pos):
            for j2, l in list(pos):
                if j == j2 and (i, l) not in pos:
                    pos.add((i, l))
                    changed = True
    return sorted(pos)


def _strict_upper_units(draw, k_min: int, k_max: int, *, min_units: int) -> tuple[int, list]:
    """A matrix size ``k`` and the strictly upper-triangular matrix units it draws, closed under
    products (:func:`_close_positions`): the span of a nilpotent subalgebra of ``gl(k)``."""
    k = draw(st.integers(k_min, k_max), label="matrix size k")
    upper = [(i, j) for i in range(k) for j in range(i + 1, k)]
    chosen = draw(
        st.lists(st.sampled_from(upper), min_size=min_units, max_size=len(upper), unique=True),
        label="matrix units",
    )
    return k, _close_positions(k, chosen)


@st.composite
def _nilpotent(draw, max_dim):
    k, pos = _strict_upper_units(draw, 3, 4, min_units=2)
    if len(pos) > max_dim:
        pos = pos[:max_dim]
        pos = [p for p in pos if all(q in pos for q in _close_positions(k, [p]))]
        pos = _close_positions(k, pos)
    assume(1 <= len(pos) <= max_dim)
    return _from_matrix_units(
        k, [], pos, f"n({k})[{','.join(f'{i}{j}' for i, j in pos)}]", ("nilpotent",)
    )


@st.composite
def _solvable(draw, max_dim):
    k, pos = _strict_upper_units(draw, 2, 3, min_units=1)
    r = draw(st.integers(1, k), label="diagonal directions")
    assume(r + len(pos) <= max_dim)
    diag = [
        draw(st.lists(st.integers(-2, 2), min_size=k, max_size=k), label=f"diagonal {t}")
        for t in range(r)
    ]
    dm = np.array(diag, dtype=float)
    assume(np.linalg.matrix_rank(dm) == r)  # independent diagonals: a basis
    return _from_matrix_units(k, diag, pos, f"b({k})[d={diag},{pos}]", ("solvable",))


@st.composite
def _semidirect(draw, max_dim):
    """``R |x_M R^m`` with a random rational matrix ``M`` (solvable; nilpotent when M is)."""
    m = draw(st.integers(1, min(3, max_dim - 1)), label="m")
    entries = draw(st.lists(st.integers(-3, 3), min_size=m * m, max_size=m * m), label="M entries")
    M = np.array([Fraction(v, 2) for v in entries], dtype=object).reshape(m, m)
    assume(any(v != 0 for v in M.flat))
    return abelian(1).semidirect(np.array([M]), name=f"R|x_M R^{m}[M={[str(v) for v in M.flat]}]")


@st.composite
def _bianchi_b(draw):
    kind = draw(st.sampled_from(["III", "IV", "V", "VI_h", "VII_h"]), label="Bianchi class B type")
    if kind in ("III", "IV", "V"):
        return bianchi(kind)
    # a = p/q rational so that the constants stay rational: h = -a^2 (VI_h), a^2 (VII_h)
    a = draw(
        st.sampled_from([Fraction(1, 2), Fraction(1, 3), Fraction(2), Fraction(3, 2), Fraction(3)]),
        label="a",
    )
    if kind == "VI_h":
        assume(a != 1)
        return bianchi("VI_h", -a * a)
    return bianchi("VII_h", a * a)


def basis_changes(n: int, *, max_entry: int = 1):
    """A well-conditioned rational change of basis ``C = D L U``: unit triangular ``L``, ``U``
    with entries in ``{-max_entry/2, ..., max_entry}`` steps of 1/2 and ``D`` diagonal in
    ``{1, 2, -1, 1/2}``. ``cond(C) <= (1 + n max_entry)^(2n) * 4`` by construction."""
    _check_bound("n", n, low=1, allow_none=False)
    if max_entry not in (0, 1, 2):
        raise ValueError(f"max_entry must be 0, 1 or 2, got {max_entry!r}")
    return _basis_changes(n, max_entry)


@st.composite
def _basis_changes(draw, n, max_entry):
    vals = st.sampled_from(
        [Fraction(0), Fraction(1, 2), Fraction(-1, 2), Fraction(1), Fraction(-1)][
            : 2 * max_entry + 1
        ]
    )
    m = n * (n - 1) // 2
    lo = draw(st.lists(vals, min_size=m, max_size=m), label="lower entries")
    up = draw(st.lists(vals, min_size=m, max_size=m), label="upper entries")
    dg = draw(
        st.lists(
            st.sampled_from([Fraction(1), Fraction(2), Fraction(-1), Fraction(1, 2)]),
            min_size=n,
            max_size=n,
        ),
        label="diagonal",
    )
    L = np.array([[Fraction(int(i == j)) for j in range(n)] for i in range(n)], dtype=object)
    U = L.copy()
    t = 0
    for i in range(n):
        for j in range(i):
            L[i, j] = lo[t]
            U[j, i] = up[t]
            t += 1
    D = np.diag(np.array(dg, dtype=object))
    D[D == 0] = Fraction(0)
    for i in range(n):
        for j in range(n):
            if i != j:
                D[i, j] = Fraction(0)
    return D.dot(L).dot(U)


def _pool(*, max_dim, semisimple=None):
    out = []
    for name in CATALOGUE_NAMES:
        alg = catalogue(name)
        if alg.dim > max_dim:
            continue
        if semisimple is not None and alg.is_semisimple() != semisimple:
            continue
        out.append(alg)
    return out


def lie_algebras(
    *,
    min_dim: int = 1,
    max_dim: int = 6,
    semisimple: bool | None = None,
    solvable: bool | None = None,
    nilpotent: bool | None = None,
    families=None,
):
    """Real Lie algebras with exact rational (or exact algebraic, for the catalogue) constants.

    Families (:data:`FAMILIES`): the catalogue; class A and class B Bianchi
    algebras (class B with rational ``a``, drawn often: the so(3) trap);
    catalogue algebras in a random well-conditioned rational basis
    (:func:`basis_changes`); random solvable subalgebras of upper-triangular
    ``k x k`` matrices; random nilpotent subalgebras of strictly
    upper-triangular ones; ``R |x_M R^m`` with a random rational ``M``; direct
    sums of two small algebras. ``semisimple``, ``solvable``, ``nilpotent``
    filter (``None``: either); ``min_dim``/``max_dim`` bound the dimension.
    """
    _check_bound("min_dim", min_dim, low=1, allow_none=False)
    _check_bound("max_dim", max_dim, low=1, allow_none=False)
    if max_dim < min_dim:
        raise ValueError(f"max_dim = {max_dim} must be >= min_dim = {min_dim}")
    for nm, v in (("semisimple", semisimple), ("solvable", solvable), ("nilpotent", nilpotent)):
        _check_flag(nm, v)
    if semisimple and (solvable or nilpotent):
        raise ValueError("an algebra cannot be semisimple and solvable (or nilpotent)")
    if nilpotent and solvable is False:
        raise ValueError("nilpotent algebras are solvable: nilpotent=True needs solvable != False")
    fams = tuple(families) if families is not None else FAMILIES
    bad = [f for f in fams if f not in FAMILIES]
    if bad:
        raise ValueError(f"unknown families {bad}; expected a subset of {FAMILIES}")
    if semisimple:
        fams = tuple(
            f for f in fams if f in ("catalogue", "basis_changed", "direct_sum", "bianchi_class_a")
        )
        if max_dim < 3:
            raise ValueError("semisimple algebras have dimension >= 3: max_dim must be >= 3")
    if nilpotent:
        fams = tuple(
            f
            for f in fams
            if f
            in (
                "catalogue",
                "basis_changed",
                "nilpotent",
                "semidirect",
                "bianchi_class_a",
                "direct_sum",
            )
        )
    if not fams:
        raise ValueError("lie_algebras: the filters leave no family to draw from")
    weighted = [f for f in fams for _ in range(_WEIGHTS[f])]
    return _lie_algebras(weighted, min_dim, max_dim, semisimple, solvable, nilpotent)


@st.composite
def _lie_algebras(draw, weighted, min_dim, max_dim, semisimple, solvable, nilpotent):
    fam = draw(st.sampled_from(weighted), label="family")
    if fam == "catalogue":
        pool = _pool(max_dim=max_dim, semisimple=True if semisimple else None)
        assume(pool)
        alg = draw(st.sampled_from(pool), label="catalogue algebra")
    elif fam == "bianchi_class_a":
        kinds = ["VIII", "IX"] if semisimple else ["I", "II", "VI0", "VII0", "VIII", "IX"]
        alg = bianchi(draw(st.sampled_from(kinds), label="Bianchi class A type"))
    elif fam == "bianchi_class_b":
        alg = draw(_bianchi_b(), label="Bianchi class B")
    elif fam == "basis_changed":
        pool = [
            a
            for a in _pool(max_dim=min(max_dim, 6), semisimple=True if semisimple else None)
            if a.is_rational
        ]
        assume(pool)
        base = draw(st.sampled_from(pool), label="algebra to change basis of")
        c = draw(basis_changes(base.dim), label="change of basis C")
        alg = base.change_basis(c, name=f"{base.name}[C={[str(v) for v in c.flat]}]")
    elif fam == "solvable":
        alg = draw(_solvable(max_dim), label="solvable upper-triangular")
    elif fam == "nilpotent":
        alg = draw(_nilpotent(max_dim), label="nilpotent strictly upper-triangular")
    elif fam == "semidirect":
        assume(max_dim >= 2)
        alg = draw(_semidirect(max_dim), label="R |x R^m")
    else:  # direct_sum
        small = (
            [
                a
                for a in _pool(max_dim=min(3, max_dim - 1), semisimple=True if semisimple else None)
                if a.is_rational
            ]
            if max_dim >= 2
            else []
        )
        assume(small)
        g = draw(st.sampled_from(small), label="first summand")
        rest = [a for a in small if a.dim <= max_dim - g.dim]
        assume(rest)
        h = draw(st.sampled_from(rest), label="second summand")
        alg = g.direct_sum(h)
    assume(min_dim <= alg.dim <= max_dim)
    if semisimple is not None:
        assume(alg.is_semisimple() == semisimple)
    if solvable is not None:
        assume(is_solvable(alg) == solvable)
    if nilpotent is not None:
        assume(is_nilpotent(alg) == nilpotent)
    return alg


def catalogue_algebras(*, names=None, max_dim: int | None = None, semisimple: bool | None = None):
    """Algebras of the catalogue, optionally filtered by dimension or semisimplicity."""
    pool = []
    for name in names or CATALOGUE_NAMES:
        alg = catalogue(name)
        if max_dim is not None and alg.dim > max_dim:
            continue
        if semisimple is not None and alg.is_semisimple() != semisimple:
            continue
        pool.append(alg)
    if not pool:
        raise ValueError("catalogue_algebras: the filters leave no algebra")
    return st.sampled_from(pool)


def _exact_matrix(m) -> sympy.Matrix:
    """A matrix of numbers as an exact sympy matrix (:func:`refimpl._validate.exact_sympy`: floats at
    their binary value, strings parsed as decimal or rational literals, never evaluated)."""
    rows = np.asarray(m, dtype=object)
    if rows.ndim != 2:
        raise ValueError(f"_exact_matrix needs a 2-d array of numbers, got shape {rows.shape}")
    return sympy.Matrix(
        [
            [exact_sympy(v, f"matrix entry [{i}, {j}]") for j, v in enumerate(r)]
            for i, r in enumerate(rows)
        ]
    )


def _in_span(basis, theta) -> bool:
    """``theta`` in the span of ``basis`` (exact ranks of the flattened upper triangles)."""
    n = np.asarray(theta).shape[0]
    iu = [(a, b) for a in range(n) for b in range(a + 1, n)]
    cols = [[exact_sympy(bm[a, b], "basis entry") for a, b in iu] for bm in basis]
    t = [exact_sympy(theta[a, b], "theta entry") for a, b in iu]
    if not cols:
        return all(v == 0 for v in t)
    m = sympy.Matrix(cols).T
    return m.rank() == sympy.Matrix.hstack(m, sympy.Matrix(t)).rank()


def _coboundary_from(algebra: LieAlgebra, xi) -> np.ndarray:
    """``Theta_ab = -xi_m f^m_ab`` (zeven3), exact."""
    f = algebra.f_exact
    n = algebra.dim
    return np.array(
        [
            [-sum((xi[m] * f[m, a, b] for m in range(n)), sympy.Integer(0)) for b in range(n)]
            for a in range(n)
        ],
        dtype=object,
    )


def cocycles(
    algebra: LieAlgebra,
    *,
    exact: bool = True,
    zero: bool | None = None,
    coboundary: bool | None = None,
):
    """A random 2-cocycle of ``algebra``: a rational combination of an exact basis of Z^2.

    ``exact=True`` returns an object array of exact numbers; ``False`` floats.
    ``zero=True`` forces Theta = 0, ``False`` forbids it.
    ``coboundary=True`` draws ``Theta = -xi.f`` from a rational ``xi`` (zeven3);
    ``False`` draws a cocycle whose class in ``H^2`` is non-zero (needs
    ``H^2 != 0``: never for a semisimple algebra, by Whitehead's lemma).
    """
    if not isinstance(algebra, LieAlgebra):
        raise ValueError(f"algebra must be a LieAlgebra, got {type(algebra).__name__}")
    _check_flag("zero", zero)
    _check_flag("coboundary", coboundary)
    if coboundary is False and zero is True:
        raise ValueError("zero=True and coboundary=False contradict: 0 is a coboundary")
    if coboundary is True and not algebra.is_exact:
        raise ValueError(
            f"cocycles(coboundary=True) needs exact structure constants ({algebra.name})"
        )
    basis = cocycle_basis(algebra, exact=algebra.is_exact)
    b2 = None
    if coboundary is False:
        b2 = coboundary_basis(algebra, exact=algebra.is_exact)
        if len(b2) == len(basis):
            raise ValueError(
                f"{algebra.name} has H^2 = 0: no cocycle with a non-zero class (coboundary=False)"
            )
    if zero is False and not basis:
        raise ValueError(f"{algebra.name} has no non-zero cocycle")
    return _cocycles(algebra, exact, zero, coboundary, basis, b2)


@st.composite
def _cocycles(draw, algebra, exact, zero, coboundary, basis, b2):
    n = algebra.dim
    if coboundary is True and zero is not True:
        xi = draw(st.lists(rationals(), min_size=n, max_size=n), label="xi")
        t = _coboundary_from(algebra, xi)
        if zero is False:
            assume(any(v != 0 for v in t.flat))
        return t if exact else np.array(t, dtype=float)
    if zero is True or not basis:
        t = np.zeros((n, n), dtype=object)
        t[:, :] = 0
        return t if exact else np.zeros((n, n))
    coefs = draw(
        st.lists(rationals(), min_size=len(basis), max_size=len(basis)).filter(
            lambda c: zero is not False or any(c)
        ),
        label="cocycle coefficients",
    )
    t = sum((c * b for c, b in zip(coefs, basis)), np.zeros((n, n), dtype=object))
    if coboundary is False:
        assume(not _in_span(b2, t))
    if exact:
        return t
    return np.array(t, dtype=float)


def upsilons(
    n: int, *, exact: bool = True, zero: bool | None = None, scale: Fraction = Fraction(1, 2)
):
    """A random antisymmetric ``(n, n)`` Upsilon with rational entries of size ``<= 9/8 * scale``."""
    _check_bound("n", n, low=1, allow_none=False)
    _check_flag("zero", zero)
    if zero is False and n < 2:
        raise ValueError("upsilons(zero=False) needs n >= 2: a 1x1 antisymmetric matrix is 0")
    if not isinstance(scale, (int, Fraction)) or scale <= 0:
        raise ValueError(f"scale must be a positive int or Fraction, got {scale!r}")
    return _upsilons(n, exact, zero, Fraction(scale))


@st.composite
def _upsilons(draw, n, exact, zero, scale):
    u = np.zeros((n, n), dtype=object)
    u[:, :] = Fraction(0)
    if zero is True:
        return u if exact else np.zeros((n, n))
    vals = draw(
        st.lists(rationals(), min_size=n * (n - 1) // 2, max_size=n * (n - 1) // 2).filter(
            lambda v: zero is not False or any(v)
        ),
        label="upsilon entries",
    )
    k = 0
    for i in range(n):
        for j in range(i + 1, n):
            u[i, j] = vals[k] * scale
            u[j, i] = -u[i, j]
            k += 1
    return u if exact else np.array(u, dtype=float)


def phi_condition(f, theta, upsilon, pi) -> float:
    """2-norm condition number of ``Phi = 1 + S Upsilon`` in float64 (for regime checks)."""
    f = np.asarray(f, dtype=float)
    S = np.einsum("m,mab->ab", np.asarray(pi, dtype=float), f) - np.asarray(theta, dtype=float)
    Phi = np.eye(f.shape[0]) + S @ np.asarray(upsilon, dtype=float)
    return float(np.linalg.cond(Phi))


def degeneracy_condition(f, theta, upsilon, pi) -> float:
    """``kappa = ||Phi^-1||_2 max(1, ||S||_2 ||Upsilon||_2)``: the condition of ``Phi = 1 + S Upsilon``
    with respect to the data S, Upsilon (a relative error eps in S or Upsilon moves ``Phi^-1`` by
    ``~ kappa eps`` relative). Infinite on the degenerate set Delta = 0 (vier12). Unlike
    ``cond(Phi)`` it also grows near Delta = 0 when Phi is a multiple of 1 (e.g. every
    2-dimensional algebra, where ``S Upsilon = -s u 1``)."""
    f = np.asarray(f, dtype=float)
    S = np.einsum("m,mab->ab", np.asarray(pi, dtype=float), f) - np.asarray(theta, dtype=float)
    U = np.asarray(upsilon, dtype=float)
    Phi = np.eye(f.shape[0]) + S @ U
    sv = np.linalg.svd(Phi, compute_uv=False)
    if sv[-1] == 0:
        return float("inf")
    return float(max(1.0, np.linalg.norm(S, 2) * np.linalg.norm(U, 2)) / sv[-1])


def _degenerate_roots(f, theta, upsilon, pi0, d):  # candidates only: points() validates cond(Phi)
    """Real ``t`` with ``det Phi(pi0 + t d) = 0``: ``Phi = Phi0 + t S(d) U``, a generalized eigenproblem."""
    n = f.shape[0]
    S0 = np.einsum("m,mab->ab", pi0, f) - theta
    S1 = np.einsum("m,mab->ab", d, f)
    Phi0 = np.eye(n) + S0 @ upsilon
    B = S1 @ upsilon
    try:
        lam = np.linalg.eigvals(np.linalg.solve(Phi0, B))
    except np.linalg.LinAlgError:
        return []
    roots = [
        -1.0 / complex(v).real
        for v in lam
        if abs(complex(v).imag) < 1e-12 * max(1, abs(v)) and abs(v) > 1e-12
    ]
    return [r for r in roots if np.isfinite(r) and abs(r) < 1e6]


def central_tolerance(algebra: LieAlgebra) -> float:
    """Bound on ``max|ad_x|`` per unit ``max|x|`` that float64 rounding alone can produce when
    ``x`` is central: each entry is a sum of n products, so ``4 n^2 eps max|f|``."""
    n = algebra.dim
    return 4 * n * n * float(np.finfo(float).eps) * float(np.max(np.abs(algebra.f), initial=0.0))


def points(algebra: LieAlgebra, theta=None, upsilon=None, *, regime: str = "generic"):
    """A point ``(x, pi)`` (float64 arrays) in a conditioning ``regime`` (see the module docstring).

    ``near_degenerate`` needs ``theta`` and ``upsilon`` (float or exact) and
    approaches a real root of ``Delta`` along a random line; the regime is
    rejected (``assume``-style filtering) where Delta has no real root there.
    """
    if regime not in REGIMES:
        raise ValueError(f"regime must be one of {REGIMES}, got {regime!r}")
    if not isinstance(algebra, LieAlgebra):
        raise ValueError(f"algebra must be a LieAlgebra, got {type(algebra).__name__}")
    if regime == "near_degenerate" and (theta is None or upsilon is None):
        raise ValueError("points(regime='near_degenerate') needs theta and upsilon")
    return _points(algebra, theta, upsilon, regime)


@st.composite
def _points(draw, algebra, theta, upsilon, regime):
    n = algebra.dim
    unit = st.floats(-1, 1, allow_nan=False, allow_infinity=False)
    vec = st.lists(unit, min_size=n, max_size=n).map(np.array)
    x = draw(vec, label="x direction")
    pi = draw(vec, label="pi")
    if regime == "generic":
        return x * 0.8, pi * 2
    if regime == "large_momenta":
        mag = draw(st.sampled_from([1e2, 1e4, 1e6]), label="momentum magnitude")
        return x * 0.8, pi * mag
    if regime == "near_chart_boundary":
        # |ad_x| close to (but below) 2 pi for compact directions: scale x so
        # that ||ad_x||_F / 2pi = rho.
        # A direction in the centre (ad_x = 0, e.g. any x of an abelian algebra) has no chart
        # boundary: it is returned unscaled. x is normalised first so that a tiny direction
        # (1e-245) does not underflow ||ad_x||.
        rho = draw(st.sampled_from([0.6, 0.8, 0.9]), label="rho")
        if not x.any():
            return x, pi
        x = x / np.max(np.abs(x))
        # Components below eps of the largest do not change the direction, but they can make
        # ad_x subnormal (x = (1, 1e-308, 0) on b(2)): ||ad_x|| then squares to 0 in the norm and
        # the rescaling would overflow. They are flushed to zero.
        x = np.where(np.abs(x) < np.finfo(float).eps, 0.0, x)
        adx = algebra.ad(x)
        # A direction central up to rounding (||ad_x|| <= n eps max|f| with |x| <= 1) has no chart
        # boundary either: scaling rounding noise up to 2 pi would be meaningless.
        if np.max(np.abs(adx)) <= central_tolerance(algebra) * np.max(np.abs(x)):
            return x, pi
        nrm = np.linalg.norm(adx)
        return x * (rho * 2 * np.pi / nrm), pi
    # near_degenerate
    if theta is None or upsilon is None:
        raise ValueError("points(regime='near_degenerate') needs theta and upsilon")
    th = np.array(theta, dtype=float)
    up = np.array(upsilon, dtype=float)
    d = draw(vec, label="line direction")
    roots = _degenerate_roots(algebra.f, th, up, pi, d) if np.any(d) and np.any(up) else []
    if not roots:
        reject()
    t0 = roots[int(draw(st.integers(0, len(roots) - 1), label="root"))]
    target = 10.0 ** draw(st.integers(2, 12), label="log10 cond target")
    sign = draw(st.sampled_from([-1.0, 1.0]), label="side")
    # Near a simple root kappa(t0 + s) ~ K / |s| (degeneracy_condition): calibrate K at a probe
    # offset, place the point at s = K / target, and keep it only if kappa really is in
    # [1e2, 1e12] (a double root, or a root where Phi stays regular, fails the check).
    dn = float(np.linalg.norm(d))
    scale_t = max(1.0, abs(t0))
    probe = 1e-6 * scale_t / dn
    K = degeneracy_condition(algebra.f, th, up, pi + (t0 + sign * probe) * d) * probe
    s_off = K / target
    pt = pi + (t0 + sign * s_off) * d
    c = degeneracy_condition(algebra.f, th, up, pt)
    assume(np.isfinite(c) and 1e2 <= c <= 1e12)
    return x * 0.8, pt


# ======================================================================= models
def models(
    *,
    algebras=None,
    exact: bool = True,
    coboundary: bool | None = None,
    upsilon_zero: bool | None = None,
    theta_zero: bool | None = None,
):
    """A model ``{"algebra", "theta", "upsilon"}``: a Lie algebra (default :func:`lie_algebras`),
    a 2-cocycle Theta (zeven1) and an antisymmetric Upsilon (vier1)."""
    _check_flag("upsilon_zero", upsilon_zero)
    _check_flag("theta_zero", theta_zero)
    _check_flag("coboundary", coboundary)
    if algebras is not None and not isinstance(algebras, st.SearchStrategy):
        raise ValueError(
            f"algebras must be a strategy of LieAlgebra, got {type(algebras).__name__}"
        )
    return _models(algebras, exact, coboundary, upsilon_zero, theta_zero)


@st.composite
def _models(draw, algebras, exact, coboundary, upsilon_zero, theta_zero):
    alg = draw(algebras if algebras is not None else lie_algebras(max_dim=5), label="algebra")
    if upsilon_zero is False:
        assume(alg.dim >= 2)  # a 1x1 antisymmetric Upsilon is 0
    theta = draw(cocycles(alg, exact=exact, coboundary=coboundary, zero=theta_zero), label="theta")
    ups = draw(upsilons(alg.dim, exact=exact, zero=upsilon_zero), label="upsilon")
    return {"algebra": alg, "theta": theta, "upsilon": ups}


SCENE_OUTPUTS = ("pi", "x", "Gamma", "energy", "casimirs", "momentum_map")


def _dyadic(k: int = 16, denominator: int = 8):
    """Dyadic rationals: exact in float64 and in TOML."""
    return st.integers(-k, k).map(lambda v: v / denominator)


def scenes(*, names=None, potential: bool | None = None, batch: bool | None = None):
    """A scene as a plain dict in the TOML format of :func:`refimpl.flows.parse_scene`
    (docs/design.md "Scenes"); every number is a float with an exact dyadic value, so a TOML
    round trip is lossless. Keys:

    ``name``; ``algebra`` (catalogue name) or ``f`` (``(n, n, n)`` nested lists);
    ``theta`` (``(n, n)``) or ``xi`` (``(n,)``, Theta = -xi.f); ``upsilon`` (``(n, n)``)
    or ``tau`` (su(2)); ``inertia`` (symmetric positive definite) or
    ``inertia_diagonal``; optional table ``potential`` (``L``, ``gamma``: gravity,
    twee15); ``x0``, ``pi0`` (``(n,)`` or a batch ``(N, n)`` when ``batch``); ``t_end``;
    ``samples``; ``tol``; ``outputs``.
    """
    _check_flag("potential", potential)
    _check_flag("batch", batch)
    pool = (
        list(names) if names is not None else [n for n in CATALOGUE_NAMES if catalogue(n).dim <= 6]
    )
    unknown = [n for n in pool if n not in CATALOGUE_NAMES]
    if unknown:
        raise ValueError(f"scenes: unknown algebra names {unknown}")
    if not pool:
        raise ValueError("scenes: names is empty")
    return _scenes(pool, potential, batch)


def _nested(a) -> list:
    return np.asarray(a, dtype=float).tolist()


_EPS3 = np.array(  # Levi-Civita eps_lmn, the loader's tau convention
    [
        [[float((i - j) * (j - k) * (k - i) / 2) for k in range(3)] for j in range(3)]
        for i in range(3)
    ]
)


@st.composite
def _scenes(draw, pool, potential, batch):
    name = draw(st.sampled_from(pool), label="algebra")
    alg = catalogue(name)
    n = alg.dim
    vec = st.lists(_dyadic(), min_size=n, max_size=n)
    scene = {"name": f"drawn {name}"}
    if draw(st.booleans(), label="algebra as f"):
        scene["f"] = _nested(alg.f)
    else:
        scene["algebra"] = name
    if draw(st.booleans(), label="theta as xi"):
        scene["xi"] = draw(vec, label="xi")
    else:
        th = draw(cocycles(alg, exact=True), label="theta")
        scene["theta"] = _nested(np.array(th, dtype=float))
    if name in ("su(2)", "Bianchi IX") and draw(st.booleans(), label="upsilon as tau"):
        scene["tau"] = [v / 4 for v in draw(vec, label="tau")]
    else:
        u = draw(upsilons(n, exact=True), label="upsilon")
        scene["upsilon"] = _nested(np.array(u, dtype=float))
    diag = draw(st.lists(st.integers(1, 8), min_size=n, max_size=n), label="principal moments")
    if draw(st.booleans(), label="diagonal inertia"):
        scene["inertia_diagonal"] = [float(d) for d in diag]
    else:
        off = draw(
            st.lists(st.integers(-1, 1), min_size=n * (n - 1) // 2, max_size=n * (n - 1) // 2),
            label="inertia off-diagonal",
        )
        inertia = np.diag([float(d) + n for d in diag])  # diagonally dominant: SPD
        t = 0
        for i in range(n):
            for j in range(i + 1, n):
                inertia[i, j] = inertia[j, i] = off[t] / 2
                t += 1
        scene["inertia"] = inertia.tolist()
    if potential is not False and (potential or draw(st.booleans(), label="gravity")):
        scene["potential"] = {"L": draw(vec, label="L"), "gamma": draw(vec, label="gamma")}
    count = draw(st.integers(2, 4), label="batch size") if batch else 1
    x0 = [[v / 4 for v in draw(vec, label="x0")] for _ in range(count)]
    pi0 = [draw(vec, label="pi0") for _ in range(count)]
    scene["x0"], scene["pi0"] = (x0, pi0) if batch else (x0[0], pi0[0])
    # a scene starts off the degenerate set Pi_1 (vier12), where no flow exists: the loader refuses
    # such starts by name, so a start with Delta = det(1 + S Upsilon) = 0 is drawn again
    f = np.asarray(alg.f, dtype=float)
    theta = (
        -np.einsum("k,kab->ab", np.asarray(scene["xi"], dtype=float), f)
        if "xi" in scene
        else np.asarray(scene["theta"], dtype=float)
    )
    upsilon = (
        np.einsum("l,lmn->mn", np.asarray(scene["tau"], dtype=float), _EPS3)  # the loader's tau
        if "tau" in scene
        else np.asarray(scene["upsilon"], dtype=float)
    )
    res = _fast.poisson_batch(f, theta, upsilon, np.zeros((count, n)), np.asarray(pi0, dtype=float))
    if np.any(res.degenerate):
        reject()
    scene["t_end"] = float(draw(st.sampled_from([1, 2, 5, 10]), label="t_end"))
    scene["samples"] = draw(st.integers(2, 200), label="samples")
    scene["tol"] = 10.0 ** -draw(st.integers(4, 12), label="digits")
    scene["outputs"] = draw(
        st.lists(st.sampled_from(SCENE_OUTPUTS), min_size=1, unique=True), label="outputs"
    )
    return scene


# ============================================================ negative controls
def jacobi_breaking_constants(*, n: int = 3):
    """Antisymmetric rational ``f[m, a, b]`` that break the Jacobi identity (negative control).

    Returned as an object array of Fractions (a :class:`LieAlgebra` refuses them).
    """
    _check_bound("n", n, low=3, allow_none=False)
    return _jacobi_breaking(n)


@st.composite
def _jacobi_breaking(draw, n):

    k = n * n * (n - 1) // 2
    vals = draw(st.lists(st.integers(-2, 2), min_size=k, max_size=k), label="structure constants")
    f = np.full((n, n, n), Fraction(0), dtype=object)
    t = 0
    for m in range(n):
        for a in range(n):
            for b in range(a + 1, n):
                f[m, a, b] = Fraction(vals[t])
                f[m, b, a] = -f[m, a, b]
                t += 1
    assume(any(v != 0 for v in jacobi_residual(f).flat))
    return f


def non_cocycles(algebra: LieAlgebra):
    """Antisymmetric rational Theta with ``delta_2 Theta != 0`` (breaks zeven1; negative control)."""
    if not isinstance(algebra, LieAlgebra):
        raise ValueError(f"algebra must be a LieAlgebra, got {type(algebra).__name__}")
    n = algebra.dim
    if len(cocycle_basis(algebra)) == n * (n - 1) // 2:
        raise ValueError(f"every 2-form of {algebra.name} is a cocycle: no non-cocycle exists")
    return _non_cocycles(algebra)


@st.composite
def _non_cocycles(draw, algebra):

    n = algebra.dim
    vals = draw(
        st.lists(rationals(), min_size=n * (n - 1) // 2, max_size=n * (n - 1) // 2),
        label="theta entries",
    )
    t = np.full((n, n), Fraction(0), dtype=object)
    k = 0
    for a in range(n):
        for b in range(a + 1, n):
            t[a, b] = vals[k]
            t[b, a] = -vals[k]
            k += 1
    res = delta2(algebra, t, exact=algebra.is_exact)
    assume(any(v != 0 for v in np.asarray(res).flat))
    return t
