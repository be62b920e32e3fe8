"""Faithful matrix representations of any Lie algebra given by structure constants, and the
group-level ``exp`` / ``log`` through them (what re-basing flows need to re-express ``g = exp(x)``).

Construction (:func:`faithful_representation`, cached per algebra by the bytes of ``f``;
conventions of docs/conventions.md, ``[e_a, e_b] = f^m_ab e_m``, ``ad_x[m, b] = x^a f[m, a, b]``):

1. centre ``z = 0`` (every semisimple algebra in any basis): the adjoint representation
   ``rho(e_a) = ad_{e_a} = f[:, a, :]``;
2. ``z`` non-zero but ``z ∩ [g, g] = 0``: ``ad (+) alpha o p`` with ``p: g -> g/[g, g] = R^k`` and
   ``alpha`` the faithful representation of the abelian ``R^k`` by strictly upper-triangular
   ``(k+1) x (k+1)`` matrices ``alpha(u) = sum_i u_i E_{0, i+1}``; the kernel is ``z ∩ [g, g] = 0``;
3. otherwise (nilpotent algebras, and the rest such as the oscillator algebra or
   ``h3 (+) su(2)`` in a mixed basis), an Ado-type construction from a nilpotent ideal ``n``
   containing ``z ∩ [g, g]`` with a complementary *subalgebra* ``s`` (``g = n ⋊ s``):

   * ``n`` acts on the polynomials on its simply connected group ``N`` (exponential coordinates
     ``y``) of weighted degree ``<= c`` (``c`` the nilpotency class; ``y^i`` has weight ``w`` when
     its basis vector lies in ``C^w(n) \\ C^{w+1}(n)`` of an adapted basis of the lower central
     series) by the left-invariant vector fields
     ``X_a = [phi1(-ad_y)^-1]^m_a d/dy^m = sum_k beta_k (ad_y^k)^m_a d/dy^m``,
     ``sum_k beta_k A^k = A / (1 - e^-A)`` (finite: ``ad_y`` is nilpotent). ``[X_a, X_b] = X_[a,b]``;
     ``X_a`` lowers the weighted degree, so the space is invariant, and ``X_a y^m = delta^m_a + ...``
     makes it faithful on ``n``. This is the dual of the regular representation on the truncated
     enveloping algebra ``U(n)/U(n)_{>c}``: exp of it is right translation ``phi -> phi(. g)``;
   * ``s`` acts by the derivations ``D_s = ad_s|_n``, i.e. by the linear vector fields
     ``Z_s = -(D_s y)^m d/dy^m`` (the automorphisms ``exp(t D_s)`` of ``N``), which preserve the
     weighted degree; ``[Z_s, X_y] = X_{D_s y}`` and ``[Z_s, Z_t] = Z_[s,t]``, so
     ``rho(y + s) = X_y + Z_s`` is a representation of ``g = n ⋊ s``;
   * the total is ``ad (+) rho`` (``(+) alpha o p`` when still needed), injective because ``rho``
     is injective on ``n ⊇ z ∩ [g, g]``. For a nilpotent algebra ``n = g`` and ``rho`` alone is
     faithful (no ``ad`` block).

   ``n`` is the radical of the Killing form (an ideal containing ``z``) when that is nilpotent,
   else ``[g, rad g]`` (``rad g = [g, g]^⊥`` of the Killing form; ``[g, rad g]`` lies in the
   nilradical and contains ``z ∩ [g, g]``). The complement ``s`` is made a subalgebra by de Graaf's
   layer-by-layer correction: with the defect ``[s_i, s_j] - c^l_ij s_l = delta_ij in C^k(n)``,
   solve the linear equations ``delta_ij + [s_i, tau_j] - [s_j, tau_i] - c^l_ij tau_l = 0`` mod
   ``C^{k+1}(n)`` for ``tau_i in C^k(n)`` and set ``s_i += tau_i``. When no such ``s`` exists (a
   non-split extension) :class:`RepresentationError` names that condition.

When every constant is a small rational (a float that equals ``p/q``, ``q <= 10^6``, or a
:class:`~refimpl._algebra.LieAlgebra` with rational ``f_exact``) the construction runs in exact
rational arithmetic (sympy) and the representation is checked to be a homomorphism
``[rho(a), rho(b)] = f^m_ab rho(e_m)`` and injective exactly; otherwise in float64, checked with
the error model written in :func:`check_representation`.

Logarithm (:meth:`Representation.log`), the documented choice of ``x`` with ``exp(x) = g``:

(a) the principal logarithm of ``rho(g)`` when it lies in ``rho(g)`` (eigenvalues of ``rho(x)`` with
    imaginary parts in ``(-pi, pi)``): unique;
(b) else the principal logarithm of ``Ad(g)`` (eigenvalues of ``ad_x`` in the strip ``|Im| < pi``,
    unique modulo the centre ``z``, the minimum-norm preimage), plus the central ``zeta in z`` with
    ``exp(rho(zeta)) = exp(-rho(x_ad)) rho(g)`` (a unipotent matrix, so ``zeta`` is unique);
(c) on the cut locus of both (an eigenvalue of ``Ad(g)`` on the negative real axis, e.g. a rotation
    by ``pi``) the limit from the fixed direction ``d = (1, 2, ..., n) / |.|``: (a)/(b) applied to
    ``g exp(-s d)``, ``s = 10^-6``, then Newton steps ``x <- x + phi1(-ad_x)^-1 y`` with
    ``exp(y) = exp(-x) g`` until ``exp(x) = g``. Eigenvalues of ``ad_x`` then have ``|Im| <= pi``;
(d) when no logarithm of ``Ad(g)`` in the strip lies in ``ad(g)`` (su(3) in the adjoint
    representation once two roots' angles add up beyond ``pi``): the branch of ``log Ad(g)`` with
    the smallest total shift ``sum |m_k|`` of its conjugate eigenvalue pairs by ``2 pi i m_k`` that
    lies in ``ad(g)`` (:meth:`Representation._log_branches`).
The mpmath version takes (a)/(b) at the working precision, else the float64 choice refined by Newton.

For nilpotent algebras ``exp`` is a global diffeomorphism and ``phi1(-ad_x)`` never degenerates
(``ad_x`` is nilpotent): flows need no re-basing and ``x`` is the unique logarithm.
"""

from __future__ import annotations

import functools
import itertools
import warnings
from dataclasses import dataclass, field
from fractions import Fraction
from itertools import combinations

import mpmath
import numpy as np
import scipy.linalg
import sympy

from . import _full_state_kernel as _fk
from ._algebra import LieAlgebra
from ._catalogue import CATALOGUE_NAMES, catalogue
from ._phi import expm, phi1, phi1_mp

__all__ = [
    "Representation",
    "RepresentationError",
    "catalogue_match",
    "check_representation",
    "faithful_representation",
    "representation_for",
]

EPS = np.finfo(float).eps
LOOSE = (
    1e-12  # mp logarithm: acceptance when the constants close only to float rounding (see mp_log)
)
RANK_RTOL = (
    1e-9  # float path only: singular values below RANK_RTOL * ||M|| count as zero (rank decisions)
)


def _logm(G):
    """The principal logarithm of a float64 matrix: the compiled inverse scaling and squaring of
    :func:`refimpl._full_state_kernel.logm` (real or complex; a 10 x 10 matrix in ~0.1 ms, scipy's
    ``logm`` ~2 ms), else -- where that one refuses (an eigenvalue on or near the closed negative axis,
    or more than 40 square roots) -- scipy's ``logm`` without its accuracy warning. Every caller
    accepts a logarithm only through ``Representation._accept`` (``exp(rho(x)) = G`` within the
    written model), never by either routine's own estimate."""
    G = np.asarray(G)
    if G.ndim == 2 and G.shape[0] == G.shape[1] and G.dtype.kind in "fc" and G.shape[0] > 0:
        A = np.ascontiguousarray(G, dtype=complex if G.dtype.kind == "c" else float)
        L = np.empty_like(A)
        if np.all(np.isfinite(A)) and _fk.logm(A, L):
            return L
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return scipy.linalg.logm(G)


def _exp_growth(M: np.ndarray) -> float:
    """How far ``exp`` spreads an error at ``M`` (float64, real or complex ``(r, r)``): an estimate of
    ``max_s |e^(sM)|_1 |e^((1-s)M)|_1`` over ``s`` in ``[0, 1]``, sampled at ``s = k/8``.

    ``exp(M + D) - exp(M) = int_0^1 e^(sM) D e^((1-s)M) ds + O(D^2)``, so an error ``D`` in a
    logarithm's coordinates shows in ``exp`` at most ``|D|`` times this. The bound it estimates
    replaces the worst case ``exp(|M|_1)``, which is useless as a discriminator: for the adjoint
    matrix of a rotation-like element (Bianchi VII_h, ``|M|_1 = 32``) it is 5e13 while the sampled
    growth is ~50, so a logarithm that is off by ``O(|G|)`` passed (a reference flow ended at a wrong
    ``x``). Capped at ``exp(50)`` (float64 cannot discriminate beyond).
    """
    M = np.asarray(M)
    cap = float(np.exp(50.0))
    if not np.all(np.isfinite(M)) or float(np.linalg.norm(M, 1)) > 8 * 50.0:
        return cap
    step = expm(M / 8)
    powers = [np.eye(M.shape[0], dtype=step.dtype)]
    for _ in range(8):
        powers.append(powers[-1] @ step)
    norms = [float(np.abs(P).sum(axis=0).max()) for P in powers]
    return min(cap, max(norms[k] * norms[8 - k] for k in range(9)))


class RepresentationError(ValueError):
    """No faithful matrix representation could be built (or a given one is not faithful)."""


def catalogue_match(f):
    """The catalogue algebra with exactly these structure constants (for its representation), or None."""
    for name in CATALOGUE_NAMES:
        alg = catalogue(name)
        if alg.f.shape == f.shape and np.array_equal(alg.f, f) and alg.rep is not None:
            return alg
    return None


# ---------------------------------------------------------------- linear algebra (exact or float)
class _LA:
    """Rank decisions, kernels and solves either exactly (sympy rationals in numpy object arrays)
    or in float64 (SVD with relative threshold :data:`RANK_RTOL`)."""

    def __init__(self, exact: bool, scale: float = 1.0):
        self.exact = exact
        self.scale = max(1.0, float(scale))  # float path: the size of the structure constants

    def _svd_rank(self, A):
        """Float rank: singular values above ``RANK_RTOL max(s_max, scale)`` (noise of size
        ``eps scale`` in brackets is never counted as a direction)."""
        U, s, Vt = np.linalg.svd(A)
        tol = RANK_RTOL * max(float(s[0]) if s.size else 0.0, self.scale)
        return U, s, Vt, int(np.sum(s > tol))

    def one(self):
        return sympy.Integer(1) if self.exact else 1.0

    def zeros(self, *shape):
        if self.exact:
            out = np.empty(shape, dtype=object)
            out.fill(sympy.Integer(0))
            return out
        return np.zeros(shape)

    def eye(self, n):
        out = self.zeros(n, n)
        for i in range(n):
            out[i, i] = self.one()
        return out

    @staticmethod
    def _obj(M):
        return np.array(M.tolist(), dtype=object).reshape(M.shape)

    def nullspace(self, A):
        """Columns spanning ``{v : A v = 0}``."""
        A = np.asarray(A)
        if self.exact:
            ns = (
                sympy.Matrix(A.tolist()).nullspace()
                if A.size
                else [sympy.eye(A.shape[1])[:, i] for i in range(A.shape[1])]
            )
            return np.hstack([self._obj(v) for v in ns]) if ns else self.zeros(A.shape[1], 0)
        if A.shape[0] == 0:
            return np.eye(A.shape[1])
        _, _, Vt, r = self._svd_rank(A)
        return Vt[r:].T.copy()

    def colbasis(self, A):
        """Columns spanning the column space of ``A`` (a basis)."""
        A = np.asarray(A)
        if A.shape[1] == 0:
            return self.zeros(A.shape[0], 0)
        if self.exact:
            _, piv = sympy.Matrix(A.tolist()).rref()
            return A[:, list(piv)]
        U, _, _, r = self._svd_rank(A)
        return U[:, :r].copy()

    def rank(self, A):
        return self.colbasis(A).shape[1]

    def independent_cols(self, A):
        """Indices of a maximal independent set of columns, greedily from the left."""
        A = np.asarray(A)
        if self.exact:
            return list(sympy.Matrix(A.tolist()).rref()[1])
        keep = []
        for j in range(A.shape[1]):
            if self.rank(A[:, keep + [j]]) == len(keep) + 1:
                keep.append(j)
        return keep

    def solve(self, A, b):
        """A solution ``x`` of ``A x = b`` (any, free parameters zero), or None if inconsistent."""
        A, b = np.asarray(A), np.asarray(b)
        if self.exact:
            try:
                sol, params = sympy.Matrix(A.tolist()).gauss_jordan_solve(sympy.Matrix(b.tolist()))
            except ValueError:
                return None
            sol = sol.subs({p: 0 for p in params})
            return self._obj(sol).reshape(A.shape[1], *b.shape[1:])
        x, *_ = np.linalg.lstsq(A, b, rcond=None)
        scale = max(1.0, float(np.max(np.abs(A), initial=0.0))) * max(
            1.0, float(np.max(np.abs(x), initial=0))
        )
        if np.max(np.abs(A @ x - b), initial=0.0) > 1e3 * EPS * max(A.shape) * scale:
            return None
        return x

    def chop(self, M):
        """Float path: entries below ``RANK_RTOL scale`` set to zero (rounding noise of exact zeros of the
        structure: a coordinate of a bracket in the adapted basis that vanishes exactly)."""
        if self.exact:
            return M
        M = np.array(M, dtype=float)
        M[np.abs(M) < RANK_RTOL * self.scale] = 0.0
        return M

    def is_zero(self, M, scale=1.0):
        M = np.asarray(M)
        if self.exact:
            return all(v == 0 for v in M.flat)
        return (
            float(np.max(np.abs(M), initial=0.0))
            <= 1e3 * EPS * max(1.0, scale) * max(1, M.size) ** 0.5
        )


def _rational_constants(f):
    """``f`` as an object array of sympy rationals when every entry is a small rational, else None."""
    if isinstance(f, LieAlgebra):
        if f.is_rational:
            return np.asarray(f.f_exact, dtype=object)
        f = f.f
    f = np.asarray(f, dtype=float)
    out = np.empty(f.shape, dtype=object)
    for idx, v in np.ndenumerate(f):
        fr = Fraction(float(v)).limit_denominator(10**6)
        if float(fr) != v:
            return None
        out[idx] = sympy.Rational(fr.numerator, fr.denominator)
    return out


# ---------------------------------------------------------------- the algebra's subspaces
def _bracket(f, u, v):
    return np.einsum("mab,a,b->m", f, u, v)


def _centre(la, f):
    n = f.shape[0]
    M = f.transpose(0, 2, 1).reshape(n * n, n)  # rows (m, b), column a: f[m, a, b]
    return la.nullspace(M)


def _derived(la, f):
    n = f.shape[0]
    return la.colbasis(f.reshape(n, n * n))


def _intersection_dim(la, A, B):
    return A.shape[1] + B.shape[1] - la.rank(np.hstack([A, B]))


def _lower_central_series(la, f, N):
    """``[C^1 = N, C^2 = [N, N], ...]`` as column bases (ideal ``N`` of g), ending with the zero space."""
    series = [N]
    while series[-1].shape[1] and len(series) <= f.shape[0] + 1:
        C = series[-1]
        cols = [_bracket(f, N[:, i], C[:, j]) for i in range(N.shape[1]) for j in range(C.shape[1])]
        nxt = la.colbasis(np.array(cols, dtype=N.dtype).T if cols else la.zeros(f.shape[0], 0))
        if nxt.shape[1] == C.shape[1]:
            return None  # not nilpotent
        series.append(nxt)
    return series if series[-1].shape[1] == 0 else None


def _killing(f):
    return np.einsum("man,nbm->ab", f, f)


def _is_ideal(la, f, N):
    n = f.shape[0]
    cols = [
        _bracket(f, np.eye(n, dtype=int)[a], N[:, j]) for a in range(n) for j in range(N.shape[1])
    ]
    if not cols:
        return True
    return la.rank(np.hstack([N, np.array(cols, dtype=N.dtype).T])) == N.shape[1]


# ---------------------------------------------------------------- complement subalgebra (de Graaf)
def _complement_subalgebra(la, f, N, series):
    """A basis ``S`` (columns) of a subalgebra with ``g = n (+) s``, or None."""
    n = f.shape[0]
    E = la.eye(n)
    S = E[:, [j - N.shape[1] for j in la.independent_cols(np.hstack([N, E]))[N.shape[1] :]]]
    q = S.shape[1]
    if q <= 1:
        return S
    pairs = list(combinations(range(q), 2))
    NS = np.hstack([N, S])
    for k in range(len(series) - 1):
        Ck, Cnext = series[k], series[k + 1]
        coef = {}
        defect = {}
        for i, j in pairs:
            sol = la.solve(NS, _bracket(f, S[:, i], S[:, j]))
            if sol is None:
                return None
            coef[i, j] = sol[N.shape[1] :]
            defect[i, j] = N @ sol[: N.shape[1]]
        Q = (
            la.nullspace(Cnext.T).T if Cnext.shape[1] else la.eye(n)
        )  # functionals vanishing on C^{k+1}
        dk, rq = Ck.shape[1], Q.shape[0]
        A = la.zeros(len(pairs) * rq, q * dk)
        rhs = la.zeros(len(pairs) * rq)
        for p_idx, (i, j) in enumerate(pairs):
            rows = slice(p_idx * rq, (p_idx + 1) * rq)
            rhs[rows] = -(Q @ defect[i, j])
            for r in range(dk):
                c = Ck[:, r]
                A[rows, j * dk + r] += Q @ _bracket(f, S[:, i], c)
                A[rows, i * dk + r] -= Q @ _bracket(f, S[:, j], c)
                for l_ in range(q):
                    if coef[i, j][l_] != 0:
                        A[rows, l_ * dk + r] -= coef[i, j][l_] * (Q @ c)
        tau = la.solve(A, rhs)
        if tau is None:
            return None
        for i in range(q):
            S[:, i] = S[:, i] + Ck @ tau[i * dk : (i + 1) * dk]
        NS = np.hstack([N, S])
    for i, j in pairs:  # final check: s closed under the bracket
        sol = la.solve(NS, _bracket(f, S[:, i], S[:, j]))
        if sol is None or not la.is_zero(sol[: N.shape[1]], float(np.max(np.abs(f.astype(float))))):
            return None
    return S


# ---------------------------------------------------------------- polynomial vector fields
def _add(p, mono, c):
    if c != 0:
        v = p.get(mono, 0) + c
        if v == 0:
            p.pop(mono, None)
        else:
            p[mono] = v


def _mul(p, q):
    out: dict = {}
    for m1, c1 in p.items():
        for m2, c2 in q.items():
            _add(out, tuple(a + b for a, b in zip(m1, m2)), c1 * c2)
    return out


def _beta(K, one):
    """Coefficients of ``A / (1 - e^-A) = sum_k beta_k A^k``, k < K (inverse of sum (-1)^k A^k/(k+1)!)."""
    a = [
        one * (-1) ** k / sympy.factorial(k + 1)
        if isinstance(one, sympy.Basic)
        else (-1) ** k / float(np.prod(np.arange(1, k + 2)))
        for k in range(K)
    ]
    beta = [one]
    for k in range(1, K):
        beta.append(-sum(a[j] * beta[k - j] for j in range(1, k + 1)))
    return beta


def _nilpotent_ideal_rep(la, f, N, series, S):
    """``rho(y + s) = X_y + Z_s`` on polynomials of weighted degree ``<= c`` (module docstring)."""
    n = f.shape[0]
    one = la.one()
    # adapted basis Y of n: deepest layer first, each layer completing the next deeper one
    cols, weights = [], []
    for w in range(len(series) - 2, -1, -1):
        cur = np.array(cols, dtype=N.dtype).T if cols else la.zeros(n, 0)
        M = np.hstack([cur, series[w]])
        for j in la.independent_cols(M)[len(cols) :]:
            cols.append(M[:, j])
            weights.append(w + 1)  # series[w] = C^{w+1}(n)
    Y = np.array(cols, dtype=N.dtype).T
    order = np.argsort(weights, kind="stable")
    Y, weights = Y[:, order], [weights[i] for i in order]
    p, c = Y.shape[1], max(weights)
    q = S.shape[1]
    YS = np.hstack([Y, S])
    # coordinates: structure constants of n in Y, derivations D_s on n
    cY = la.zeros(p, p, p)
    for i in range(p):
        for j in range(p):
            sol = la.solve(Y, _bracket(f, Y[:, i], Y[:, j]))
            cY[:, i, j] = sol
    D = la.zeros(q, p, p)
    for s in range(q):
        for j in range(p):
            D[s, :, j] = la.solve(Y, _bracket(f, S[:, s], Y[:, j]))
    cY, D = la.chop(cY), la.chop(D)
    # monomials of weighted degree <= c
    monos = [()]
    for i in range(p):
        monos = [
            m + (e,)
            for m in monos
            for e in range(c // weights[i] + 1)
            if sum(a * weights[k] for k, a in enumerate(m)) + e * weights[i] <= c
        ]
    index = {m: k for k, m in enumerate(monos)}
    unit = [tuple(1 if k == i else 0 for k in range(p)) for i in range(p)]
    zero = tuple([0] * p)

    def deriv(poly, m):
        out: dict = {}
        for mono, cf in poly.items():
            if mono[m]:
                _add(out, tuple(e - (k == m) for k, e in enumerate(mono)), cf * mono[m])
        return out

    def matrix(field_coeffs):
        """Matrix of ``sum_m coeff_m(y) d/dy^m`` on the monomial basis."""
        M = la.zeros(len(monos), len(monos))
        for jcol, mono in enumerate(monos):
            img: dict = {}
            for m, cm in enumerate(field_coeffs):
                if cm:
                    for mm, cc in _mul(cm, deriv({mono: one}, m)).items():
                        _add(img, mm, cc)
            for mm, cc in img.items():
                if mm not in index:
                    raise RepresentationError(f"internal: weighted degree not preserved ({mm})")
                M[index[mm], jcol] = M[index[mm], jcol] + cc
        return M

    beta = _beta(c + 1, one)
    X = []
    for a in range(p):
        v = [{zero: one} if m == a else {} for m in range(p)]  # (ad_y)^0 e_a
        coeff = [dict(t) for t in v]
        for k in range(1, c + 1):
            nv = [{} for _ in range(p)]
            for m in range(p):
                for i in range(p):
                    for b in range(p):
                        if cY[m, i, b] != 0 and v[b]:
                            for mono, cf in v[b].items():
                                _add(
                                    nv[m],
                                    tuple(e + (kk == i) for kk, e in enumerate(mono)),
                                    cf * cY[m, i, b],
                                )
            v = nv
            for m in range(p):
                for mono, cf in v[m].items():
                    _add(coeff[m], mono, beta[k] * cf)
        X.append(matrix(coeff))
    Z = []
    for s in range(q):
        coeff = [{} for _ in range(p)]
        for m in range(p):
            for j in range(p):
                if D[s, m, j] != 0:
                    _add(coeff[m], unit[j], -D[s, m, j])
        Z.append(matrix(coeff))
    ops = X + Z
    coords = la.solve(YS, la.eye(n))  # e_a = YS @ coords[:, a]
    r = len(monos)
    rho = la.zeros(n, r, r)
    for a in range(n):
        for k in range(p + q):
            if coords[k, a] != 0:
                rho[a] = rho[a] + coords[k, a] * ops[k]
    return rho


# ---------------------------------------------------------------- the representation object
@dataclass(frozen=True)
class Representation:
    """A faithful representation ``rho(e_a) = mats[a]`` (``(n, r, r)``) of the algebra ``f``.

    ``kind``: ``catalogue``, ``adjoint``, ``adjoint+abelian``, ``nilpotent`` (the polynomial
    representation alone) or ``adjoint+ideal`` (Ado-type, optionally ``+abelian``);
    ``nilpotent``: the algebra is nilpotent (exp is a global diffeomorphism, no re-basing);
    ``exact``: the matrices as sympy rationals (object array) when built exactly;
    ``centre``: a basis (columns) of the centre, used by the logarithm.
    """

    f: np.ndarray
    mats: np.ndarray
    kind: str
    nilpotent: bool
    centre: np.ndarray
    exact: np.ndarray | None = field(default=None, repr=False)
    exponential: bool = False  # completely solvable (real roots): exp is a global diffeomorphism

    @property
    def dim(self) -> int:
        return int(self.mats.shape[-1])

    # ------------------------------------------------------------ float64
    def matrix(self, x):
        """``rho(x) = x^a E_a`` for x of shape (..., n)."""
        return np.einsum("...a,aij->...ij", x, self.mats)

    def exp(self, x):
        """``rho(exp(x))`` for x of shape (..., n) (:func:`refimpl._phi.expm` on the stack)."""
        return expm(self.matrix(np.asarray(x, dtype=float)))

    def _project(self, X, rows):
        """Least-squares coordinates of ``X`` in the span of ``rows`` (flattened, real and imaginary)."""
        B = np.concatenate(
            [rows.real.reshape(rows.shape[0], -1), rows.imag.reshape(rows.shape[0], -1)], axis=1
        ).T
        rhs = np.concatenate([X.real.ravel(), X.imag.ravel()])
        x, *_ = np.linalg.lstsq(B, rhs, rcond=None)
        return x, float(np.max(np.abs(B @ x - rhs), initial=0.0))

    def _accept(self, x, G, cond_log=1.0):
        """``exp(rho(x)) = G`` to rounding: ``|exp(M) - G|_max <= c eps cond_log max(1, |M|_1) growth r``
        with ``M = rho(x)``, ``c = 10^3``, ``growth`` = :func:`_exp_growth` (at least ``|G|``, the
        scale) and ``r`` the matrix size: a backward-stable logarithm is off by ``~eps |M|``.
        ``cond_log``: the logarithm's own conditioning where it is known to be poor (a Newton start
        at distance ``s`` from the cut locus: ``1 / s``)."""
        if x is None or not np.all(np.isfinite(x)):
            return False
        M = self.matrix(x)
        E = expm(M)
        err = np.max(np.abs(E - G))
        tol = 1e3 * EPS * cond_log * max(1.0, float(np.linalg.norm(M, 1))) * self.dim
        if err <= tol * max(1.0, float(np.linalg.norm(E, 1))):  # growth >= |exp(M)|_1: accepted
            return True
        return bool(err <= tol * max(1.0, _exp_growth(M)))

    def _log_a(self, G):
        X = _logm(G)
        if not np.all(np.isfinite(X)):
            return None
        x, _ = self._project(X, self.mats)
        return x

    def _log_b(self, G, Ad):
        n = self.f.shape[0]
        A = _logm(Ad)
        if not np.all(np.isfinite(A)):
            return None
        adb = np.array([self.f[:, a, :] for a in range(n)])
        x_ad, _ = self._project(A, adb)  # lstsq: the minimum-norm preimage (orthogonal to z in R^n)
        if self.centre.shape[1] == 0:
            return x_ad
        Gc = expm(-self.matrix(x_ad)) @ G
        L = _logm(Gc)
        if not np.all(np.isfinite(L)):
            return None
        Z = np.einsum("ak,aij->kij", self.centre.astype(float), self.mats)
        zc, _ = self._project(L, Z)
        return x_ad + self.centre.astype(float) @ zc

    def log(self, G, Ad=None):
        """``x`` with ``exp(x) = g`` for ``G = rho(g)`` (the choice (a)/(b)/(c) of the module docstring).

        ``Ad``: ``Ad(g)`` if known (else computed from the ``ad`` block... passed by the flows)."""
        G = np.asarray(G)
        if Ad is None:
            raise ValueError("Representation.log needs Ad(g)")
        for cand in self._candidates(G, Ad):
            with np.errstate(all="ignore"):
                try:
                    x = cand()
                except (ValueError, np.linalg.LinAlgError):
                    x = None
            if (
                x is not None
                and np.all(np.isfinite(x))
                and np.max(np.abs(x.imag if np.iscomplexobj(x) else 0)) == 0
                and self._accept(np.real(x), G)
            ):
                return np.real(x)
        return self._log_cut(G, Ad)

    def _candidates(self, G, Ad):
        """(a) and (b) as callables; (b) left out where it is (a) again (:meth:`_is_ad`)."""
        a = lambda: self._log_a(G)  # noqa: E731
        return (a,) if self._is_ad(G, Ad) else (a, lambda: self._log_b(G, Ad))

    def _is_ad(self, G, Ad) -> bool:
        """The adjoint representation of an algebra without centre (``rho = ad``): ``G`` is ``Ad(g)``
        itself (``Ad`` the same matrix up to the rounding of its computation), so (b), the log of
        ``Ad`` projected on the same basis, repeats (a) and is left out."""
        if self.kind == "adjoint" and self.centre.shape[1] == 0 and G.shape == Ad.shape:
            n = self.f.shape[0]
            return np.array_equal(self.mats, np.array([self.f[:, b, :] for b in range(n)]))
        return False

    def _direction(self):
        n = self.f.shape[0]
        d = np.arange(1, n + 1, dtype=float)
        return d / np.linalg.norm(d)

    def _log_cut(self, G, Ad):
        """(c): from ``g exp(-s d)`` then Newton steps (cut locus: an eigenvalue on the negative axis)."""
        d = self._direction()
        s = 1e-6
        Gp = G @ expm(-s * self.matrix(d))
        if self._is_ad(G, Ad):  # Ad(g exp(-s d)) is that same matrix: (b) stays left out
            Adp = Gp
        else:
            Adp = Ad @ expm(-s * np.einsum("a,mab->mb", d, self.f))
        x = None
        for cand in self._candidates(Gp, Adp):
            with np.errstate(all="ignore"):
                try:
                    x = np.real(cand())
                except (ValueError, np.linalg.LinAlgError, TypeError):
                    x = None
            if x is not None and self._accept(x, Gp, cond_log=1 / s):  # a start: its branch
                break
            x = None
        if x is None:
            # (d) no principal logarithm in the algebra (e.g. su(3) in the adjoint representation when
            # the angles of two roots add up beyond pi): the branch search on Ad(g)
            return self._log_branches(G, Ad)
        for _ in range(40):
            R = expm(-self.matrix(x)) @ G
            y = self._log_a(R)
            if y is None or not np.all(np.isfinite(y)):
                break
            A = phi1(-np.einsum("a,mab->mb", x, self.f))
            step = np.linalg.solve(A, np.real(y))
            x = x + step / max(1.0, float(np.linalg.norm(step)))  # damped: steps of length <= 1
            if self._accept(x, G):
                return x
        raise RepresentationError(
            "no logarithm x of g found (no principal logarithm in the algebra, and "
            "Newton's iteration on exp(x) = g did not converge)"
        )

    def _log_branches(self, G, Ad):
        """(d): ``Ad(g) = V diag(l) V^-1``; the logarithms ``V diag(log l + 2 pi i m) V^-1`` with integer
        shifts ``m_k in {0, +-1, +-2}`` on conjugate pairs (opposite on the partner), tried in order of
        increasing ``sum |m_k|``; the first lying in ``ad(g)`` (projection residual at rounding level) is
        ``ad_x``, corrected by the centre as in (b). Raises when none does."""
        n = self.f.shape[0]
        w, V = np.linalg.eig(Ad)
        Vi = np.linalg.inv(V)
        L0 = np.log(w.astype(complex))
        pairs, used = [], set()
        for k in np.argsort(-w.imag):
            if k in used or w[k].imag <= 1e-9:
                continue
            kc = int(
                np.argmin(np.abs(w - np.conj(w[k])) + 1e9 * np.isin(np.arange(n), list(used) + [k]))
            )
            used |= {k, kc}
            pairs.append((k, kc))
        adb = np.array([self.f[:, a, :] for a in range(n)])
        for m in _shifts(len(pairs)):
            L = L0.copy()
            for (k, kc), mk in zip(pairs, m):
                L[k] += 2j * np.pi * mk
                L[kc] -= 2j * np.pi * mk
            X = (V * L) @ Vi
            x_ad, res = self._project(X, adb)
            if res > 1e-6 * max(1.0, float(np.max(np.abs(X)))):
                continue
            x = np.real(x_ad)
            if self.centre.shape[1]:
                with np.errstate(all="ignore"):
                    Lc = _logm(expm(-self.matrix(x)) @ G)
                Z = np.einsum("ak,aij->kij", self.centre.astype(float), self.mats)
                zc, _ = self._project(Lc, Z)
                x = x + self.centre.astype(float) @ np.real(zc)
            if self._accept(x, G):
                return x
        raise RepresentationError("no logarithm x of g found: no branch of log Ad(g) lies in ad(g)")

    # ------------------------------------------------------------ mpmath
    def mp_matrix(self, x, Fm=None):
        """``rho(x)`` as an mpmath matrix at the current precision (exact entries when known). For the
        adjoint representation with the model's constants ``Fm[m][a, b]`` given, ``ad_x`` from those
        (bit-for-bit the model's own algebra at the working precision)."""
        if Fm is not None and self.kind == "adjoint":
            n = len(Fm)
            return mpmath.matrix(
                [
                    [mpmath.fsum(x[a] * Fm[m][a, b] for a in range(n)) for b in range(n)]
                    for m in range(n)
                ]
            )
        r = self.dim
        X = mpmath.zeros(r, r)
        src = self.exact if self.exact is not None else self.mats
        for a in range(len(x)):
            if x[a] == 0:
                continue
            Ea = src[a]
            for i in range(r):
                for j in range(r):
                    v = Ea[i, j]
                    if v != 0:
                        X[i, j] += x[a] * _mpnum(v)
        return X

    def mp_exp(self, x, Fm=None):
        return mpmath.expm(self.mp_matrix(x, Fm))

    def mp_log(self, G, Ad, Fm):
        """mpmath version of :meth:`log`: ``G = rho(g)``, ``Ad = Ad(g)`` (mpmath matrices); ``Fm[m][a, b]``
        the structure constants at the working precision. Accepts when ``|exp(rho(x)) - G|_1 <=
        10^(-3 dps / 4) max(1, |rho(x)|_1) growth``, ``growth`` = :func:`_exp_growth` of ``rho(x)``
        (in float64: only its size matters)."""
        n = self.f.shape[0]
        tol = mpmath.mpf(10) ** (-(mpmath.mp.dps * 3 // 4))
        src = self.exact if self.exact is not None else self.mats
        adrows = [[Fm[m][a, b] for a in range(n)] for m in range(n) for b in range(n)]
        rows = (
            adrows
            if self.kind == "adjoint"
            else [
                [_mpnum(src[a][i, j]) for a in range(n)]
                for i in range(self.dim)
                for j in range(self.dim)
            ]
        )

        def ad_of(x):
            return mpmath.matrix(
                [
                    [mpmath.fsum(x[a] * Fm[m][a, b] for a in range(n)) for b in range(n)]
                    for m in range(n)
                ]
            )

        def accept(x, Gt, loose=False):
            if x is None:
                return False
            X = self.mp_matrix(x, Fm)
            E = mpmath.expm(X) - Gt
            t = LOOSE if loose else tol
            err, bound = mpmath.mnorm(E, 1), t * max(1, mpmath.mnorm(X, 1))
            if err <= bound * max(1, mpmath.mnorm(Gt, 1)):  # growth >= |G|_1: accepted
                return True
            Xf = np.array(X.tolist(), dtype=complex)
            return err <= bound * max(1, _exp_growth(Xf.real if not np.any(Xf.imag) else Xf))

        def log_a(Gt):
            return _min_norm(rows, mpmath.logm(Gt))

        def log_b(Gt, Adt):
            x_ad = _min_norm(adrows, mpmath.logm(Adt))
            if self.centre.shape[1] == 0:
                return x_ad
            L = mpmath.logm(mpmath.expm(-self.mp_matrix(x_ad, Fm)) * Gt)
            k = self.centre.shape[1]
            Cm = [[_mpnum(self.centre[a, c]) for c in range(k)] for a in range(n)]
            zrows = [
                [mpmath.fsum(row[a] * Cm[a][c] for a in range(n)) for c in range(k)] for row in rows
            ]
            zc = _min_norm(zrows, L)
            return x_ad + mpmath.matrix(
                [mpmath.fsum(Cm[a][c] * zc[c] for c in range(k)) for a in range(n)]
            )

        def attempt(Gt, Adt):
            found = []
            for cand in (lambda: log_a(Gt), lambda: log_b(Gt, Adt)):
                try:
                    x = cand()
                except (ZeroDivisionError, ValueError):
                    x = None
                if x is not None and accept(x, Gt):
                    return x
                found.append(x)
            # constants given in float64 satisfy Jacobi only to rounding: the matrices generated then
            # close into a group only to ~eps, and exp(x) = g holds to that level at best
            for x in found:
                if x is not None and accept(x, Gt, loose=True):
                    return x
            return None

        x = attempt(G, Ad)
        if x is not None:
            return x
        # the float64 choice ((a)-(d) of the module docstring, the same function of g), refined by Newton
        Gf = np.array([[complex(G[i, j]) for j in range(G.cols)] for i in range(G.rows)])
        Adf = np.array([[float(Ad[i, j]) for j in range(Ad.cols)] for i in range(Ad.rows)])
        if not np.any(Gf.imag):
            Gf = Gf.real
        x = mpmath.matrix([mpmath.mpf(float(v)) for v in self.log(Gf, Adf)])
        for _ in range(60):
            y = log_a(mpmath.expm(-self.mp_matrix(x, Fm)) * G)
            x = x + mpmath.lu_solve(phi1_mp(-ad_of(x)), y)
            if mpmath.norm(y) < tol and accept(x, G):
                return x
        raise RepresentationError(
            "no logarithm of g found on the cut locus (Newton did not converge)"
        )


@functools.lru_cache(maxsize=16)
def _shifts(k: int) -> tuple:
    """The branch shifts of :meth:`Representation._log_branches` for ``k`` conjugate pairs: ``m`` in
    ``{0, +-1, +-2}^k`` by increasing ``sum |m|`` (then lexicographically), the first 4000 (built once
    per ``k``)."""
    return tuple(
        sorted(itertools.product(range(-2, 3), repeat=k), key=lambda m: (sum(map(abs, m)), m))[
            :4000
        ]
    )


def _min_norm(rows, X):
    """Minimum-norm least-squares coordinates of the matrix ``X`` (complex allowed) in the span of the
    flattened basis ``rows[ij][a]``: SVD of the stacked real and imaginary parts, singular values below
    ``10^(-dps/2)`` of the largest dropped (the kernel, e.g. the centre for the ``ad`` rows)."""
    re_rows = [[mpmath.re(v) for v in row] for row in rows] + [
        [mpmath.im(v) for v in row] for row in rows
    ]
    flat = [X[i, j] for i in range(X.rows) for j in range(X.cols)]
    b = mpmath.matrix([mpmath.re(v) for v in flat] + [mpmath.im(v) for v in flat])
    M = mpmath.matrix(re_rows)
    U, S, V = mpmath.svd_r(M)
    n = M.cols
    x = mpmath.zeros(n, 1)
    Utb = U.T * b
    smax = max((S[i] for i in range(len(S))), default=0)
    for i in range(len(S)):
        if S[i] > smax * mpmath.mpf(10) ** (-(mpmath.mp.dps // 2)):
            for a in range(n):
                x[a] += V[i, a] * Utb[i] / S[i]
    return x


def _mpnum(v):
    if isinstance(v, sympy.Basic):
        if v.is_Rational:
            return mpmath.mpf(int(v.p)) / int(v.q)
        re_, im_ = (sympy.N(w, mpmath.mp.dps + 5) for w in v.as_real_imag())
        re_, im_ = mpmath.mpf(str(re_)), mpmath.mpf(str(im_))
        return mpmath.mpc(re_, im_) if im_ else re_
    z = complex(v)
    return mpmath.mpc(z.real, z.imag) if z.imag else mpmath.mpf(z.real)


# ---------------------------------------------------------------- construction and checks
_CACHE: dict = {}


def check_representation(f, mats, *, exact=None) -> None:
    """Raise :class:`RepresentationError` unless ``mats`` is a faithful representation of ``f``.

    Homomorphism ``[E_a, E_b] = f^m_ab E_m`` and injectivity (the ``n`` matrices independent).
    With ``exact`` (sympy rationals, object array, and ``f`` rational) both hold exactly.
    Float error model: ``|[E_a, E_b] - f^m_ab E_m| <= 16 r n eps max(1, |E|)^2 max(1, |f|)`` (one
    product of ``r``-term sums and an ``n``-term sum), and the ``n``-th singular value of the
    stacked matrices above ``RANK_RTOL`` times the largest.
    """
    f = np.asarray(f.f if isinstance(f, LieAlgebra) else f)
    n = f.shape[0]
    if exact is not None:
        fe = _rational_constants(f)
        if fe is None:
            raise RepresentationError("an exact check needs rational structure constants")
        E = np.asarray(exact, dtype=object)
        comm = np.einsum("aij,bjk->abik", E, E) - np.einsum("bij,ajk->abik", E, E)
        rhs = np.einsum("mab,mij->abij", fe, E)
        bad = [idx for idx, v in np.ndenumerate(comm - rhs) if v != 0]
        if bad:
            raise RepresentationError(
                f"not a homomorphism: [rho(e_a), rho(e_b)] != f^m_ab rho(e_m) at {bad[0]}"
            )
        if sympy.Matrix(E.reshape(n, -1).tolist()).rank() != n:
            raise RepresentationError("not injective: the matrices rho(e_a) are linearly dependent")
        return
    E = np.asarray(mats)
    if E.ndim != 3 or E.shape[0] != n or E.shape[1] != E.shape[2]:
        raise RepresentationError(
            f"a representation has shape (n, r, r) with n = {n}, got {E.shape}"
        )
    comm = np.einsum("aij,bjk->abik", E, E) - np.einsum("bij,ajk->abik", E, E)
    rhs = np.einsum("mab,mij->abij", f, E)
    scale = max(1.0, float(np.max(np.abs(E)))) ** 2 * max(1.0, float(np.max(np.abs(f))))
    err = float(np.max(np.abs(comm - rhs)))
    if not err <= 16 * E.shape[1] * n * EPS * scale:
        raise RepresentationError(
            f"not a homomorphism: max |[rho(e_a), rho(e_b)] - f^m_ab rho(e_m)| = {err:.3g}"
        )
    flat = E.reshape(n, -1)
    s = np.linalg.svd(np.concatenate([flat.real, flat.imag], axis=1), compute_uv=False)
    if not s[-1] > RANK_RTOL * s[0]:
        raise RepresentationError("not injective: the matrices rho(e_a) are linearly dependent")


def faithful_representation(f) -> Representation:
    """The faithful representation of the algebra ``f`` (structure constants or a LieAlgebra), cached.

    Raises :class:`RepresentationError` naming the condition when none can be built (the
    algebra is not nilpotent, ``z ∩ [g, g] != 0``, and no nilpotent ideal containing
    ``z ∩ [g, g]`` has a complementary subalgebra)."""
    alg = f if isinstance(f, LieAlgebra) else None
    ff = np.ascontiguousarray(np.asarray(alg.f if alg is not None else f, dtype=float))
    key = ff.tobytes() + str(ff.shape).encode()
    if key in _CACHE:
        return _CACHE[key]
    fe = _rational_constants(alg if alg is not None else ff)
    exact = fe is not None
    la = _LA(exact, float(np.max(np.abs(ff), initial=0.0)))
    F = fe if exact else ff
    rep = _build(la, F, ff)
    _CACHE[key] = rep
    return rep


def _build(la, F, ff) -> Representation:
    n = F.shape[0]
    Zc = _centre(la, F)
    D = _derived(la, F)

    def done(mats, kind, nilp):
        if la.exact:
            check_representation(ff, None, exact=mats)
            fl = np.array(mats.tolist(), dtype=float)
        else:
            fl = np.asarray(mats, dtype=float)
        check_representation(ff, fl)
        return Representation(
            f=ff,
            mats=fl,
            kind=kind,
            nilpotent=nilp,
            centre=Zc,
            exact=mats if la.exact else None,
            exponential=nilp or _real_roots(ff),
        )

    adj = np.array([F[:, a, :] for a in range(n)])
    if Zc.shape[1] == 0:
        return done(adj, "adjoint", False)

    def abelian_block():
        P = la.nullspace(D.T).T  # k x n, kernel [g, g]
        k = P.shape[0]
        blk = la.zeros(n, k + 1, k + 1)
        for a in range(n):
            for i in range(k):
                blk[a, 0, i + 1] = P[i, a]
        return blk

    if _intersection_dim(la, Zc, D) == 0:
        return done(_block_diag(la, [adj, abelian_block()]), "adjoint+abelian", False)
    series = _lower_central_series(la, F, la.eye(n))
    if series is not None:  # nilpotent: g = n, s = 0
        rho = _nilpotent_ideal_rep(la, F, la.eye(n), series, la.zeros(n, 0))
        return done(rho, "nilpotent", True)
    K = _killing(F)
    cands = []
    kr = la.nullspace(K)
    if kr.shape[1] and _is_ideal(la, F, kr):
        cands.append(kr)
    rad = la.nullspace(D.T @ K)  # rad g = [g, g]^perp (Killing)
    if rad.shape[1]:
        cols = [
            _bracket(F, la.eye(n)[:, a], rad[:, j]) for a in range(n) for j in range(rad.shape[1])
        ]
        cands.append(la.colbasis(np.array(cols, dtype=F.dtype).T))
    for N in cands:
        if N.shape[1] == 0 or _intersection_dim(la, N, Zc) < _intersection_dim(la, Zc, D):
            continue
        ser = _lower_central_series(la, F, N)
        if ser is None:
            continue
        S = _complement_subalgebra(la, F, N, ser)
        if S is None:
            continue
        rho = _nilpotent_ideal_rep(la, F, N, ser, S)
        blocks = [adj, rho]
        stacked = _block_diag(la, blocks)
        kind = "adjoint+ideal"
        if la.rank(stacked.reshape(n, -1).T) < n:
            stacked = _block_diag(la, [adj, rho, abelian_block()])
            kind += "+abelian"
        return done(stacked, kind, False)
    raise RepresentationError(
        "no faithful representation could be built: the algebra is not nilpotent, its centre meets [g, g] "
        "(z ∩ [g, g] != 0), and no nilpotent ideal containing z ∩ [g, g] has a complementary subalgebra "
        "(a non-split extension; de Graaf's construction is not implemented for it)"
    )


def _real_roots(f) -> bool:
    """Solvable (Cartan: the Killing form vanishes on ``[g, g]``) with real roots: then ``exp`` is a
    global diffeomorphism and ``phi1(-ad_x)`` never degenerates (its eigenvalues ``(1 - e^-l)/l`` with
    ``l`` real are never 0), so flows keep the chart of the identity without re-basing. Roots are
    checked on the basis vectors and on six fixed pseudo-random directions (a root is a linear
    functional: complex on some vector means complex on almost every one)."""
    n = f.shape[0]
    K = _killing(f)
    D = _LA(False, float(np.max(np.abs(f), initial=0.0))).colbasis(f.reshape(n, n * n))
    scale = max(1.0, float(np.max(np.abs(f), initial=0.0)))
    if D.shape[1] and np.max(np.abs(D.T @ K @ D)) > 1e3 * EPS * n * scale**2:
        return False
    rng = np.random.default_rng(12345)
    for x in list(np.eye(n)) + list(rng.normal(size=(6, n))):
        ev = np.linalg.eigvals(np.einsum("a,mab->mb", x, f))
        if np.max(np.abs(ev.imag), initial=0.0) > 1e-7 * max(
            1.0, float(np.max(np.abs(ev), initial=0.0))
        ):
            return False
    return True


def _block_diag(la, blocks):
    n = blocks[0].shape[0]
    r = sum(b.shape[1] for b in blocks)
    out = la.zeros(n, r, r)
    o = 0
    for b in blocks:
        k = b.shape[1]
        out[:, o : o + k, o : o + k] = b
        o += k
    return out


def representation_for(f) -> Representation:
    """The representation the flows use: a LieAlgebra's own (or an exact catalogue match's) when it
    has one with exact matrices, else :func:`faithful_representation`."""
    alg = f if isinstance(f, LieAlgebra) else None
    ff = np.asarray(alg.f if alg is not None else f, dtype=float)
    if alg is None or alg.rep is None:
        alg = catalogue_match(ff) or alg
    # a representation known only in float64 (e.g. carried through a float change of basis) would cap
    # the reference's g(t) at 16 digits: it is used only with its exact matrices
    if alg is not None and alg.rep is not None and alg.rep_exact is not None:
        key = b"cat" + np.ascontiguousarray(ff).tobytes() + np.ascontiguousarray(alg.rep).tobytes()
        if key not in _CACHE:
            base = faithful_representation(ff)
            ex = None  # exact entries (rational or algebraic): evaluated at the working precision
            if alg.rep_exact is not None:
                ex = np.array([np.array(m.tolist(), dtype=object) for m in alg.rep_exact])
            _CACHE[key] = Representation(
                f=ff,
                mats=np.asarray(alg.rep),
                kind="catalogue",
                nilpotent=base.nilpotent,
                centre=base.centre,
                exact=ex,
                exponential=base.exponential,
            )
        return _CACHE[key]
    return faithful_representation(ff)
