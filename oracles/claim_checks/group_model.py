"""su(2) as 2x2 matrices ``g = exp(x^a E_a)``, ``E_a = -(i/2) sigma_a`` (docs/conventions.md), coordinates of
the first kind recovered by ``mpmath.logm`` (``x^a = -2 tr(X E_a)``), derivatives by ``mpmath.diff``: the
group model of the first-principles checks (never refimpl's frames)."""

from __future__ import annotations

import mpmath


def basis():
    s = [
        mpmath.matrix([[0, 1], [1, 0]]),
        mpmath.matrix([[0, -1j], [1j, 0]]),
        mpmath.matrix([[1, 0], [0, -1]]),
    ]
    return [s_ * mpmath.mpc(0, -0.5) for s_ in s]


def group_element(x):
    E = basis()
    return mpmath.expm(sum((x[a] * E[a] for a in range(3)), mpmath.zeros(2, 2)))


def coords(G):
    E = basis()
    X = mpmath.logm(G)
    return [
        mpmath.re(-2 * sum(X[i, j] * E[a][j, i] for i in range(2) for j in range(2)))
        for a in range(3)
    ]


def levi_civita(a, b, c) -> int:
    return ((a - b) * (b - c) * (c - a)) // 2


def ad(x):
    return mpmath.matrix(
        [[sum(x[a] * levi_civita(m, a, b) for a in range(3)) for b in range(3)] for m in range(3)]
    )


# Independent of refimpl/_phi.py on purpose: these checks judge refimpl from first principles.
def phi1(M, terms=80):
    out, term = mpmath.eye(M.rows), mpmath.eye(M.rows)
    for k in range(1, terms):
        term = term * M / (k + 1)
        out += term
    return out


X0 = ("0.4", "-0.7", "0.9")


def jacobian(fn, x, n=3):
    """``J[i][b] = d fn(x)_i / d x_b`` by mpmath.diff."""
    cols = []
    for b in range(n):
        cols.append(
            [
                mpmath.diff(
                    lambda s, i=i, b=b: fn([x[k] + (s if k == b else 0) for k in range(n)])[i], 0
                )
                for i in range(len(fn(x)))
            ]
        )
    return mpmath.matrix([[cols[b][i] for b in range(n)] for i in range(len(cols[0]))])


def maxabs(M):
    return max(
        abs(v)
        for v in (
            M if isinstance(M, list) else [M[i, j] for i in range(M.rows) for j in range(M.cols)]
        )
    )
