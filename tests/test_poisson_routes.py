"""The reference Poisson tensor (vier9) by two independent routes -- closed formulas vs inverting
the 2n x 2n matrix of omega_L -- on every catalogue algebra with random cocycles Theta and
Upsilon; its reduction to twee9/drie3 when Upsilon = 0; and the precision ladder."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests._helpers import mp_digits, mp_matrix_to_array
from tstarg.properties import cocycles, rationals, upsilons
from tstarg.properties.profiles import ref_examples
from tstarg.refimpl import CATALOGUE_NAMES, catalogue, frames
from tstarg.refimpl.reference import DegeneratePointError, Reference


def _rational_vec(n):
    return st.lists(rationals(max_numerator=9, denominator=10), min_size=n, max_size=n)


@pytest.mark.reference
@pytest.mark.parametrize("name", CATALOGUE_NAMES)
@pytest.mark.parametrize("frame", ["holonomic", "body"])
@settings(max_examples=ref_examples(0.2))
@given(data=st.data())
def test_closed_formulas_match_first_principles(name, frame, data):
    """vier9 (closed) == -(omega_L)^-1 (first principles) to >= 40 digits at dps 50."""
    alg = catalogue(name)
    n = alg.dim
    theta = data.draw(cocycles(alg), label="theta")
    ups = data.draw(upsilons(n), label="upsilon")
    x, pi = data.draw(_rational_vec(n), label="x"), data.draw(_rational_vec(n), label="pi")
    ref = Reference(50)
    try:
        P1 = ref.poisson_tensor_mp(alg, theta, ups, x, pi, route="closed", frame=frame)
    except DegeneratePointError:
        return  # Delta = 0 exactly at this rational point: no tensor exists (tested elsewhere)
    P2 = ref.poisson_tensor_mp(alg, theta, ups, x, pi, route="first_principles", frame=frame)
    digits = mp_digits(mp_matrix_to_array(P1), mp_matrix_to_array(P2))
    assert digits >= 40, f"{name}: closed vs first principles agree to {digits:.1f} digits only"


@pytest.mark.reference
@pytest.mark.parametrize("name", CATALOGUE_NAMES)
def test_upsilon_zero_reduces_to_twee9_drie3(name):
    """Upsilon = 0: {x,x} = 0, {x^a, pi_b} = L(g,e)^a_b, {pi_a, pi_b} = -(pi_k f^k_ab - Theta_ab) (drie3).

    Expected blocks are assembled here from the Van Loan frame and the structure constants."""
    alg = catalogue(name)
    n = alg.dim
    from tstarg.refimpl import cocycle_basis

    basis = cocycle_basis(alg)
    theta = sum((b * (k + 1) for k, b in enumerate(basis)), np.zeros((n, n), dtype=object))
    import sympy

    x = [sympy.Rational(k, 7) for k in (2, -3, 1, 4, -1, 2, 3, -2)][:n]
    pi = [sympy.Rational(k, 5) for k in (1, 2, -3, 1, 4, -2, 2, 1)][:n]
    ups = np.zeros((n, n), dtype=int)
    P = mp_matrix_to_array(Reference(50).poisson_tensor_mp(alg, theta, ups, x, pi))
    L = frames(alg, x, dps=50, route="vanloan")["L"]
    fe = alg.f_exact
    with mpmath.workdps(60):
        expected = np.empty((2 * n, 2 * n), dtype=object)
        for a in range(n):
            for b in range(n):
                s_ab = sum(pi[m] * fe[m, a, b] for m in range(n)) - theta[a, b]  # exact (sympy)
                expected[a, b] = mpmath.mpf(0)
                expected[a, n + b] = L[a, b]
                expected[n + a, b] = -L[b, a]
                expected[n + a, n + b] = -mpmath.mpf(
                    sympy.Float(sympy.N(s_ab, 70), 70)._to_mpmath(mpmath.mp.prec)
                )
    assert mp_digits(P, expected) >= 45


@pytest.mark.reference
@pytest.mark.parametrize("name", ["su(2)", "Bianchi VI_h(h=-2)", "h(5)", "su(3)", "sl(3,R)"])
def test_precision_ladder(name):
    """The reference agrees with itself across dps 30, 60, 120 (to ~dps - 3 digits)."""
    alg = catalogue(name)
    n = alg.dim
    from tstarg.refimpl import cocycle_basis

    basis = cocycle_basis(alg)
    theta = sum((b * (k + 2) for k, b in enumerate(basis)), np.zeros((n, n), dtype=object))
    ups = np.zeros((n, n), dtype=object)
    ups[:, :] = 0
    for i in range(n - 1):
        ups[i, i + 1], ups[i + 1, i] = "0.3", "-0.3"
    x = ["0.21", "-0.4", "0.33", "0.1", "-0.25", "0.05", "0.3", "-0.12"][:n]
    pi = ["0.7", "-1.3", "0.45", "1.1", "-0.6", "0.2", "0.9", "-0.35"][:n]
    Ps = {
        d: mp_matrix_to_array(Reference(d).poisson_tensor_mp(alg, theta, ups, x, pi))
        for d in (30, 60, 120)
    }
    assert mp_digits(Ps[30], Ps[120]) >= 27
    assert mp_digits(Ps[60], Ps[120]) >= 57


@pytest.mark.reference
@pytest.mark.parametrize("name", ["su(2)", "Bianchi IV", "se(2)", "so(4)"])
def test_tensor_inverts_omega(name):
    """P . Omega_hol = -1 (P is minus the inverse of omega_L in holonomic coordinates), and P^T = -P."""
    alg = catalogue(name)
    n = alg.dim
    ups = np.zeros((n, n), dtype=object)
    ups[:, :] = 0
    ups[0, 1], ups[1, 0] = "0.4", "-0.4"
    theta = np.zeros((n, n), dtype=int)
    x, pi = (
        ["0.3", "-0.2", "0.5", "0.1", "0.2", "-0.3"][:n],
        ["1.2", "-0.7", "0.4", "0.5", "-1", "0.3"][:n],
    )
    ref = Reference(50)
    P = ref.poisson_tensor_mp(alg, theta, ups, x, pi)
    with ref._prec():
        F, th, up = ref._model(alg, theta, ups)
        Om = ref.omega_holonomic_mp(F, th, up, ref._vec(x, n, "x"), ref._vec(pi, n, "pi"))
        prod = P * Om + mpmath.eye(2 * n)
        err = mpmath.mnorm(prod, 1)
        asym = mpmath.mnorm(P + P.T, 1)
    assert err < mpmath.mpf(10) ** -45 and asym < mpmath.mpf(10) ** -45


def test_degenerate_point_raises():
    """su(2) with Upsilon = tau.eps: at pi'.tau = 1 (the plane Pi_1, vier12) there is no tensor."""
    from tstarg.refimpl import su2

    ups = [[0, "1/2", 0], ["-1/2", 0, 0], [0, 0, 0]]  # tau = (0, 0, 1/2)
    with pytest.raises(DegeneratePointError, match="degenerate set Pi_1"):
        Reference(40).poisson_tensor(su2(), [[0] * 3] * 3, ups, ["0.1", 0, 0], [0, 0, 2])
