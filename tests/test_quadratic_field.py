"""The body field's tables are written once (refimpl/_taylor.py ``body_field_tables``): the float
field (``quadratic_field``) and the ball field of the rigorous flow (``_rigorous_flow.body_field``)
have the same monomials, and both agree with an independent route, the field expanded by sympy from
the paper's equations (twee14, twee17 sign-corrected) in exact rationals.

Error model: a float coefficient is a sum of at most ``n`` products of two float64 numbers (a
structure constant and an entry of ``I^-1``, or of ``Theta I^-1``, itself such a sum), so it errs by
at most ``2 n eps`` times the sum of the magnitudes of its terms, bounded here by
``2 n eps max|f| (1 + max|Theta|) n max|I^-1|`` (times ``C = 8``). A ball coefficient must contain
the exact one (no tolerance).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from flint import arb

from tstarg.refimpl import catalogue
from tstarg.refimpl._rigorous_flow import body_field
from tstarg.refimpl._taylor import quadratic_field
from tstarg.refimpl.model import Model

EPS = float(np.finfo(float).eps)
CASES = [
    ("su(2)", (1, 2, 3), (Fraction(1, 10), Fraction(-1, 5), Fraction(3, 10)), (0, 0, 1)),
    ("su(2)", (2, 2, 1), None, None),
    ("sl(2,R)", (3, 1, 2), None, (1, 0, 0)),
    ("se(3)", (1, 2, 3, 4, 5, 6), None, None),
    ("h(3)", (1, 3, 2), None, (0, 1, 1)),
]


def _exact_tables(f, I_diag, xi, L):
    """``{(component, monomial): coefficient}`` by sympy from ``pidot_a = -pi_m f^m_ab w_b +
    Theta_ab w_b + Gamma_m f^m_ac L^c`` and ``Gammadot_mu = w_b f^a_{b mu} Gamma_a`` (``w = I^-1
    pi``, ``Theta = -xi.f``), monomials as sorted index pairs or single indices."""
    n = f.shape[0]
    fr = [[[sp.Rational(str(f[m, a, b])) for b in range(n)] for a in range(n)] for m in range(n)]
    grav = L is not None
    d = 2 * n if grav else n
    y = sp.symbols(f"y0:{d}")
    pi, G = y[:n], y[n:]
    w = [pi[b] / sp.Rational(I_diag[b]) for b in range(n)]
    th = [
        [-sum(sp.Rational(xi[m]) * fr[m][a][b] for m in range(n)) if xi else 0 for b in range(n)]
        for a in range(n)
    ]
    rhs = []
    for a in range(n):
        e = sum(-pi[m] * fr[m][a][b] * w[b] for m in range(n) for b in range(n))
        e += sum(th[a][b] * w[b] for b in range(n))
        if grav:
            e += sum(G[m] * fr[m][a][c] * L[c] for m in range(n) for c in range(n))
        rhs.append(sp.expand(e))
    if grav:
        for mu in range(n):
            rhs.append(
                sp.expand(sum(w[b] * fr[a][b][mu] * G[a] for a in range(n) for b in range(n)))
            )
    out = {}
    for c, e in enumerate(rhs):
        for monom, coef in sp.Poly(e, *y).terms():
            if coef == 0:  # the zero polynomial (a constant component)
                continue
            idx = [i for i, p in enumerate(monom) for _ in range(p)]
            out[(c, tuple(idx) if len(idx) == 2 else idx[0])] = coef
    return d, out


def _model(name, I_diag, xi, L):
    alg = catalogue(name)
    n = alg.dim
    theta = (
        -np.einsum("k,kab->ab", np.array([float(v) for v in xi]), alg.f) if xi else np.zeros((n, n))
    )
    pot = None if L is None else {"kind": "gravity", "L": np.array(L, float), "gamma": np.eye(n)[0]}
    # the ball field gets Theta exactly (rationals), the float model its float64 rounding
    fx = np.asarray(alg.f_exact if alg.is_exact else alg.f, dtype=object)
    theta_exact = (
        np.array(
            [
                [-sum(sp.Rational(str(xi[k])) * fx[k, a, b] for k in range(n)) for b in range(n)]
                for a in range(n)
            ],
            dtype=object,
        )
        if xi
        else np.zeros((n, n))
    )
    return (
        alg,
        Model(alg, theta, np.zeros((n, n)), np.diag(np.array(I_diag, float)), pot),
        theta_exact,
        pot,
    )


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c[0]}{'-grav' if c[3] else ''}")
def test_float_and_ball_fields_are_the_exact_field(case):
    name, I_diag, xi, L = case
    alg, model, theta, pot = _model(*case)
    d, exact = _exact_tables(np.asarray(alg.f_exact if alg.is_exact else alg.f), I_diag, xi, L)
    F = quadratic_field(model)
    B, n = body_field(alg, theta, np.diag(np.array(I_diag, float)), pot)
    assert F.d == B.d == d and n == alg.dim
    got_f = {(c, k): v for c in range(d) for k, v in {**F.lin[c], **F.quad[c]}.items()}
    got_b = {(c, j): v for c, row in B.lin.items() for j, v in row}
    got_b.update({(c, (j, k)): v for c, row in B.quad.items() for j, k, v in row})
    # every exact monomial is in both tables; a monomial the exact field lacks (an exact cancellation
    # that rounding hides) may appear only with a coefficient of zero within the model / a ball holding 0
    assert set(exact) <= set(got_f) and set(exact) <= set(got_b), (
        name,
        set(exact) - set(got_f),
        set(exact) - set(got_b),
    )
    scale = (
        float(np.max(np.abs(alg.f))) * (1 + float(np.max(np.abs(model.theta)))) * n / min(I_diag)
    )
    tol = 8 * 2 * n * EPS * max(1.0, scale)
    for key in set(got_f) | set(got_b):
        q = exact.get(key, sp.Integer(0))
        if key in got_f:
            assert abs(got_f[key] - float(q)) <= tol * max(1.0, abs(float(q))), (key, got_f[key], q)
        if key in got_b:
            assert got_b[key].contains(arb(int(q.p)) / int(q.q)), (key, got_b[key], q)
