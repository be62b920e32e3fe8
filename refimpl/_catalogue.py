"""A catalogue of real Lie algebras, each with a faithful matrix representation.

Every entry is built from an explicit matrix basis where one is natural, so
that its structure constants are *computed* from the commutators (exactly,
with sympy) rather than typed in: the representation and the constants can
then not disagree.

Bianchi types follow Ellis & MacCallum, Commun. Math. Phys. 12 (1969) 108:
``C^k_ij = eps_ijl n^lk + delta^k_j a_i - delta^k_i a_j`` with
``n = diag(n1, n2, n3)``, ``a = (a, 0, 0)``; so
``[e1, e2] = n3 e3 + a e2``, ``[e2, e3] = n1 e1``, ``[e3, e1] = n2 e2 - a e3``
(1-based names; code indices 0, 1, 2). Class A has ``a = 0`` (unimodular);
class B has ``a != 0``. The group parameter is ``h = a^2 / (n2 n3)``:
VI_h (``n2 = 1, n3 = -1``, ``a = sqrt(-h)``, ``h < 0``; ``h = -1`` is type III)
and VII_h (``n2 = n3 = 1``, ``a = sqrt(h)``, ``h > 0``).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import sympy

from ._algebra import LieAlgebra, to_exact

__all__ = [
    "su2",
    "so3_other_basis",
    "sl2r",
    "abelian",
    "heisenberg",
    "bianchi",
    "aff1",
    "se2",
    "se3",
    "so4",
    "su3",
    "sl3r",
    "catalogue",
    "CATALOGUE_NAMES",
]

I = sympy.I


def _eps3() -> np.ndarray:
    f = np.full((3, 3, 3), sympy.Integer(0), dtype=object)
    for (a, b, c), s in {
        (0, 1, 2): 1,
        (1, 2, 0): 1,
        (2, 0, 1): 1,
        (0, 2, 1): -1,
        (2, 1, 0): -1,
        (1, 0, 2): -1,
    }.items():
        f[a, b, c] = sympy.Integer(s)
    return f


@lru_cache(maxsize=None)
def su2() -> LieAlgebra:
    """su(2): ``f^m_ab = eps_mab``; representation ``E_a = -(i/2) sigma_a``."""
    sig = [
        sympy.Matrix([[0, 1], [1, 0]]),
        sympy.Matrix([[0, -I], [I, 0]]),
        sympy.Matrix([[1, 0], [0, -1]]),
    ]
    mats = [-(I / 2) * s for s in sig]
    alg = LieAlgebra.from_matrix_basis(
        mats, name="su(2)", tags=("semisimple", "compact", "orthonormal")
    )
    assert all(
        alg.f_exact[m, a, b] == _eps3()[m, a, b]
        for m in range(3)
        for a in range(3)
        for b in range(3)
    )
    return alg


@lru_cache(maxsize=None)
def so3_other_basis() -> LieAlgebra:
    """so(3) (real 3x3 antisymmetric matrices) in a non-orthonormal rational basis.

    Start from ``(L_a)_bc = -eps_abc`` (which satisfies ``[L_a, L_b] = eps_abc L_c``)
    and take ``e'_0 = L_0 + L_1``, ``e'_1 = L_1``, ``e'_2 = L_0 + 2 L_2``.
    """
    eps = _eps3()
    ls = [sympy.Matrix(3, 3, lambda b, c: -eps[a, b, c]) for a in range(3)]
    mats = [ls[0] + ls[1], ls[1], ls[0] + 2 * ls[2]]
    return LieAlgebra.from_matrix_basis(
        mats, name="so(3)[other basis]", tags=("semisimple", "compact")
    )


@lru_cache(maxsize=None)
def sl2r() -> LieAlgebra:
    """sl(2, R) with basis H, E, F: ``[H,E] = 2E``, ``[H,F] = -2F``, ``[E,F] = H``."""
    h = sympy.Matrix([[1, 0], [0, -1]])
    e = sympy.Matrix([[0, 1], [0, 0]])
    f = sympy.Matrix([[0, 0], [1, 0]])
    return LieAlgebra.from_matrix_basis([h, e, f], name="sl(2,R)", tags=("semisimple",))


@lru_cache(maxsize=None)
def abelian(n: int) -> LieAlgebra:
    """R^n, represented by strictly upper-triangular translations in (n+1) x (n+1)."""
    if n < 1:
        raise ValueError(f"abelian(n) needs n >= 1, got {n}")
    mats = []
    for i in range(n):
        m = sympy.zeros(n + 1, n + 1)
        m[i, n] = 1
        mats.append(m)
    return LieAlgebra.from_matrix_basis(
        mats, name=f"R^{n}", tags=("abelian", "solvable", "nilpotent")
    )


@lru_cache(maxsize=None)
def heisenberg(k: int = 1) -> LieAlgebra:
    """h(2k+1): basis ``p_1..p_k, q_1..q_k, z`` with ``[p_i, q_i] = z``.

    Representation: (k+2) x (k+2) matrices with p_i at (0, i+1), q_i at
    (i+1, k+1) and z at (0, k+1).
    """
    if k < 1:
        raise ValueError(f"heisenberg(k) needs k >= 1, got {k}")
    d = k + 2
    mats = []
    for i in range(k):
        m = sympy.zeros(d, d)
        m[0, i + 1] = 1
        mats.append(m)
    for i in range(k):
        m = sympy.zeros(d, d)
        m[i + 1, d - 1] = 1
        mats.append(m)
    z = sympy.zeros(d, d)
    z[0, d - 1] = 1
    mats.append(z)
    return LieAlgebra.from_matrix_basis(
        mats, name=f"h({2 * k + 1})", tags=("solvable", "nilpotent")
    )


_BIANCHI_CLASS_A = {
    "I": (0, 0, 0),
    "II": (1, 0, 0),
    "VI0": (1, -1, 0),
    "VII0": (1, 1, 0),
    "VIII": (1, 1, -1),
    "IX": (1, 1, 1),
}
BIANCHI_TYPES = ("I", "II", "III", "IV", "V", "VI0", "VI_h", "VII0", "VII_h", "VIII", "IX")


@lru_cache(maxsize=None)
def bianchi(kind: str, h: object = None) -> LieAlgebra:
    """Bianchi type ``kind`` (see the module docstring); ``h`` for VI_h and VII_h.

    ``h`` may be exact (int, Fraction, string, sympy); ``a = sqrt(|h|)`` is
    then exact (possibly irrational, e.g. ``sqrt(2)``), so the reference can
    evaluate it to any precision. VI_h needs ``h < 0``, ``h != -1`` (that is
    type III); VII_h needs ``h > 0``.
    """
    if kind in _BIANCHI_CLASS_A:
        a = sympy.Integer(0)
        n1, n2, n3 = (sympy.Integer(v) for v in _BIANCHI_CLASS_A[kind])
    elif kind == "III":
        a, n1, n2, n3 = sympy.Integer(1), sympy.Integer(0), sympy.Integer(1), sympy.Integer(-1)
    elif kind == "IV":
        a, n1, n2, n3 = sympy.Integer(1), sympy.Integer(0), sympy.Integer(0), sympy.Integer(1)
    elif kind == "V":
        a, n1, n2, n3 = sympy.Integer(1), sympy.Integer(0), sympy.Integer(0), sympy.Integer(0)
    elif kind in ("VI_h", "VII_h"):
        if h is None:
            raise ValueError(f"Bianchi {kind} needs the parameter h")
        he = to_exact(h)
        if kind == "VI_h" and not (he < 0 and he != -1):
            raise ValueError(
                f"Bianchi VI_h needs h < 0 and h != -1 (h = -1 is type III), got h = {h}"
            )
        if kind == "VII_h" and not he > 0:
            raise ValueError(f"Bianchi VII_h needs h > 0 (h = 0 is VII0), got h = {h}")
        a = sympy.sqrt(abs(he))
        n1, n2, n3 = sympy.Integer(0), sympy.Integer(1), sympy.Integer(-1 if kind == "VI_h" else 1)
    else:
        raise ValueError(f"unknown Bianchi type {kind!r}; expected one of {BIANCHI_TYPES}")
    f = np.full((3, 3, 3), sympy.Integer(0), dtype=object)

    def put(i: int, j: int, vec: tuple) -> None:
        for k, v in enumerate(vec):
            f[k, i, j] = v
            f[k, j, i] = -v

    put(0, 1, (0, a, n3))  # [e1, e2] = a e2 + n3 e3
    put(1, 2, (n1, 0, 0))  # [e2, e3] = n1 e1
    put(2, 0, (0, n2, -a))  # [e3, e1] = n2 e2 - a e3
    label = f"Bianchi {kind}" + (f"(h={h})" if h is not None else "")
    tags = ["bianchi", "class A" if a == 0 else "class B"]
    if kind in ("VIII", "IX"):
        tags.append("semisimple")
    else:
        tags.append("solvable")
    alg = LieAlgebra.from_structure_constants(f, name=label, tags=tags)
    # A faithful representation: the adjoint one when the centre is trivial; for the types
    # with a centre (I, II, III) explicit matrices, checked against f by the constructor.
    adj = np.array([alg.ad(np.eye(3)[i]) for i in range(3)])
    if np.linalg.matrix_rank(adj.reshape(3, -1)) == 3:
        mats = [sympy.Matrix(3, 3, lambda m, b, i=i: f[m, i, b]) for i in range(3)]
    else:

        def E(i, j, d):
            m = sympy.zeros(d, d)
            m[i, j] = 1
            return m

        if kind == "I":  # translations of R^3
            mats = [E(0, 3, 4), E(1, 3, 4), E(2, 3, 4)]
        elif kind == "II":  # Heisenberg: [e2, e3] = e1 with e2 = E01, e3 = E12, e1 = E02
            mats = [E(0, 2, 3), E(0, 1, 3), E(1, 2, 3)]
        else:  # III = R |x R^2: ad_e1 on (e2, e3) is [[1, -1], [-1, 1]]; affine matrices
            mats = [sympy.Matrix([[1, -1, 0], [-1, 1, 0], [0, 0, 0]]), E(0, 2, 3), E(1, 2, 3)]
    rep = np.array([np.array(m.tolist(), dtype=float) for m in mats])
    return LieAlgebra.from_structure_constants(f, name=label, rep=rep, rep_exact=mats, tags=tags)


@lru_cache(maxsize=None)
def aff1() -> LieAlgebra:
    """aff(1): ``[e_0, e_1] = e_1``; e_0 = diag(1, 0), e_1 = E_01."""
    return LieAlgebra.from_matrix_basis(
        [sympy.Matrix([[1, 0], [0, 0]]), sympy.Matrix([[0, 1], [0, 0]])],
        name="aff(1)",
        tags=("solvable",),
    )


@lru_cache(maxsize=None)
def se2() -> LieAlgebra:
    """se(2): J, P1, P2 with ``[J, P1] = P2``, ``[J, P2] = -P1``; 3x3 affine matrices."""
    j = sympy.Matrix([[0, -1, 0], [1, 0, 0], [0, 0, 0]])
    p1 = sympy.Matrix([[0, 0, 1], [0, 0, 0], [0, 0, 0]])
    p2 = sympy.Matrix([[0, 0, 0], [0, 0, 1], [0, 0, 0]])
    return LieAlgebra.from_matrix_basis([j, p1, p2], name="se(2)", tags=("solvable",))


@lru_cache(maxsize=None)
def se3() -> LieAlgebra:
    """se(3): J_a, P_a with ``[J_a, J_b] = eps_abc J_c``, ``[J_a, P_b] = eps_abc P_c``; 4x4 matrices."""
    eps = _eps3()
    mats = []
    for a in range(3):
        m = sympy.zeros(4, 4)
        m[:3, :3] = sympy.Matrix(3, 3, lambda b, c: -eps[a, b, c])
        mats.append(m)
    for a in range(3):
        m = sympy.zeros(4, 4)
        m[a, 3] = 1
        mats.append(m)
    return LieAlgebra.from_matrix_basis(mats, name="se(3)", tags=())


@lru_cache(maxsize=None)
def so4() -> LieAlgebra:
    """so(4): the six ``E_ij - E_ji`` (i < j) in 4x4; semisimple, isomorphic to su(2)+su(2)."""
    mats = []
    for i in range(4):
        for j in range(i + 1, 4):
            m = sympy.zeros(4, 4)
            m[i, j] = 1
            m[j, i] = -1
            mats.append(m)
    return LieAlgebra.from_matrix_basis(
        mats, name="so(4)", tags=("semisimple", "compact", "orthonormal")
    )


@lru_cache(maxsize=None)
def su3() -> LieAlgebra:
    """su(3): ``E_a = -(i/2) lambda_a`` with the Gell-Mann matrices.

    Then ``[E_a, E_b] = f_abc E_c`` with the textbook totally antisymmetric
    ``f_123 = 1, f_147 = 1/2, f_458 = sqrt(3)/2, ...`` (exact, via sympy).
    """
    s3 = sympy.sqrt(3)
    lam = [
        [[0, 1, 0], [1, 0, 0], [0, 0, 0]],
        [[0, -I, 0], [I, 0, 0], [0, 0, 0]],
        [[1, 0, 0], [0, -1, 0], [0, 0, 0]],
        [[0, 0, 1], [0, 0, 0], [1, 0, 0]],
        [[0, 0, -I], [0, 0, 0], [I, 0, 0]],
        [[0, 0, 0], [0, 0, 1], [0, 1, 0]],
        [[0, 0, 0], [0, 0, -I], [0, I, 0]],
        [[1 / s3, 0, 0], [0, 1 / s3, 0], [0, 0, -2 / s3]],
    ]
    mats = [-(I / 2) * sympy.Matrix(m) for m in lam]
    return LieAlgebra.from_matrix_basis(
        mats, name="su(3)", tags=("semisimple", "compact", "orthonormal")
    )


@lru_cache(maxsize=None)
def sl3r() -> LieAlgebra:
    """sl(3, R): ``E_ij`` (i != j) and ``H_1 = diag(1,-1,0)``, ``H_2 = diag(0,1,-1)``."""
    mats = []
    for i in range(3):
        for j in range(3):
            if i != j:
                m = sympy.zeros(3, 3)
                m[i, j] = 1
                mats.append(m)
    mats.append(sympy.diag(1, -1, 0))
    mats.append(sympy.diag(0, 1, -1))
    return LieAlgebra.from_matrix_basis(mats, name="sl(3,R)", tags=("semisimple",))


def _entries() -> dict:
    return {
        "su(2)": su2,
        "so(3)[other basis]": so3_other_basis,
        "sl(2,R)": sl2r,
        "R^1": lambda: abelian(1),
        "R^3": lambda: abelian(3),
        "h(3)": lambda: heisenberg(1),
        "h(5)": lambda: heisenberg(2),
        **{
            f"Bianchi {k}": (lambda k=k: bianchi(k))
            for k in ("I", "II", "III", "IV", "V", "VI0", "VII0", "VIII", "IX")
        },
        "Bianchi VI_h(h=-1/4)": lambda: bianchi("VI_h", "-1/4"),
        "Bianchi VI_h(h=-2)": lambda: bianchi("VI_h", -2),
        "Bianchi VII_h(h=1/9)": lambda: bianchi("VII_h", "1/9"),
        "Bianchi VII_h(h=3)": lambda: bianchi("VII_h", 3),
        "aff(1)": aff1,
        "se(2)": se2,
        "se(3)": se3,
        "so(4)": so4,
        "su(3)": su3,
        "sl(3,R)": sl3r,
    }


CATALOGUE_NAMES = tuple(_entries())


def catalogue(name: str | None = None):
    """One algebra by its catalogue name, or (no argument) the dict of all of them.

    >>> su2 = catalogue("su(2)")
    >>> su2.dim, float(su2.f[2, 0, 1])  # [e_1, e_2] = e_3: f^3_12 = eps_312 = 1
    (3, 1.0)
    >>> catalogue("so4")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: unknown algebra 'so4'; the catalogue has su(2), ...
    """
    entries = _entries()
    if name is None:
        return {k: v() for k, v in entries.items()}
    try:
        return entries[name]()
    except KeyError:
        raise ValueError(
            f"unknown algebra {name!r}; the catalogue has {', '.join(entries)}"
        ) from None
