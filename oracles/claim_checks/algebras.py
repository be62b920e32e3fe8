"""Structure constants written out here (``[e_a, e_b] = f^m_ab e_m``, :data:`ALGEBRAS`) and random exact
models (a catalogue algebra with a random rational cocycle and Upsilon) for the exact checks."""

from __future__ import annotations

import random

import sympy as sp

from tstarg.refimpl import catalogue, cocycle_basis, exact_sympy


def random_model(name: str, seed: int):
    rnd = random.Random(seed)
    alg = catalogue(name)
    n = alg.dim
    F = alg.f_exact
    basis = cocycle_basis(alg, exact=True)
    Th = sp.zeros(n, n)
    for B_ in basis:
        Th += sp.Rational(rnd.randint(-5, 5), rnd.randint(1, 4)) * sp.Matrix(B_)
    U = sp.zeros(n, n)
    for i in range(n):
        for j in range(i + 1, n):
            v = sp.Rational(rnd.randint(-3, 3), rnd.randint(1, 3))
            U[i, j], U[j, i] = v, -v
    return alg, F, Th, U


def from_brackets(n: int, brackets: dict) -> list:
    """``F[m][a][b] = f^m_ab`` from ``{(a, b): {m: c}}`` for ``a < b`` (antisymmetry implied)."""
    F = [[[sp.Integer(0)] * n for _ in range(n)] for _ in range(n)]
    for (a, b), out in brackets.items():
        for m, c in out.items():
            F[m][a][b] = exact_sympy(c, f"f^{m}_{a}{b}")
            F[m][b][a] = -F[m][a][b]
    return F


def su2():
    return {(0, 1): {2: 1}, (1, 2): {0: 1}, (0, 2): {1: -1}}


ALGEBRAS = {
    # name: (dim, brackets, semisimple)
    "su(2)": (3, su2(), True),
    "sl(2,R)": (3, {(0, 1): {1: 2}, (0, 2): {2: -2}, (1, 2): {0: 1}}, True),  # h, e, f
    "so(4)": (
        6,
        {**su2(), (3, 4): {5: 1}, (4, 5): {3: 1}, (3, 5): {4: -1}},
        True,
    ),  # su(2) + su(2)
    "aff(1)": (2, {(0, 1): {1: 1}}, False),  # [e1, e2] = e2, solvable
    "h(3)": (3, {(0, 1): {2: 1}}, False),  # Heisenberg, nilpotent
    "u(2)": (4, su2(), False),  # su(2) + R, reductive
    "R^3": (3, {}, False),
}


def structure_constants(name: str) -> list:
    """``F[m][a][b] = f^m_ab`` of one of :data:`ALGEBRAS` (exact)."""
    try:
        n, br, _ = ALGEBRAS[name]
    except KeyError:
        raise ValueError(f"unknown algebra {name!r}; known: {sorted(ALGEBRAS)}") from None
    return from_brackets(n, br)
