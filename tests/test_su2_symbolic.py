"""Section cinq (SU(2)) symbolically: the printed objects equal those built from docs/conventions.md's W."""

from __future__ import annotations

import mpmath
import sympy as sp

from tstarg.oracles import su2_symbolic as su
from tstarg.refimpl import su2
from tstarg.refimpl.reference import Reference


def test_nondegenerate_identities():
    """vijf1-vijf5, Phi/Psi and their printed inverses, and Delta = C1^2 hold for general xi, tau, pi."""
    r = su.residuals_nondegenerate()
    assert all(r.values()), {k: v for k, v in r.items() if not v}


def test_degenerate_identities():
    """vijf6-vijf16 hold on Pi_1 with tau = (0, 0, t) for every Hamiltonian gradient."""
    r = su.residuals_degenerate()
    assert all(r.values()), {k: v for k, v in r.items() if not v}


def test_mutants_are_caught():
    """Wrong variants are rejected: C1 = 1 + pi'.tau gives det Phi != C1^2; flipping the eps term of vijf2 breaks X^T W = dH."""
    s = su.symbols()
    pi, xi, tau, Kg, Vg = s["pi"], s["xi"], s["tau"], s["K"], s["V"]
    M = su.model_matrices(pi, xi, tau)
    pp = pi + xi
    wrong_C1 = 1 + (pp.T * tau)[0]
    assert sp.expand(M["Phi"].det() - wrong_C1**2) != 0
    C1 = 1 - (pp.T * tau)[0]
    Xu = sp.Matrix(
        [
            Kg[a]
            - pp[a] * (tau.T * Kg)[0]
            + sum(su.eps(a, m, n) * Vg[m] * tau[n] for m in range(3) for n in range(3))
            for a in range(3)
        ]
    )
    # the dpi-block of X^T W is X^n + X_m U^mn; with the printed X_m (vijf3) it must equal C1 K^n
    Xd = sp.Matrix(
        [
            -Vg[m]
            + tau[m] * (pp.T * Vg)[0]
            - sum(su.eps(m, a, b) * Kg[a] * pp[b] for a in range(3) for b in range(3))
            for m in range(3)
        ]
    )
    res = sp.expand((sp.Matrix.vstack(Xu, Xd).T * M["W"]).T[3:, 0] - C1 * Kg)
    assert any(v != 0 for v in res)


def test_vijf4_matches_reference():
    """The printed vijf4 (explicit Phi^-1, Psi^-1) at a rational point with gravity equals the reference's
    Omega = phi1(-ad_x) xdot and dpi/dt (vier10, vier11) to 40 digits."""
    xi = [sp.Rational(1, 3), sp.Rational(-1, 5), sp.Rational(2, 7)]
    tau = [sp.Rational(1, 4), sp.Rational(1, 6), sp.Rational(-1, 3)]
    theta = [[-sum(xi[k] * su.eps(k, a, b) for k in range(3)) for b in range(3)] for a in range(3)]
    ups = [[sum(tau[l] * su.eps(l, m, n) for l in range(3)) for n in range(3)] for m in range(3)]
    I = [[2, 0, 0], [0, 3, 0], [0, 0, 5]]
    Lv, gam = ["1/5", "-1/2", "1"], ["3/5", "3/10", "-9/10"]
    x, pi = ["2/5", "-7/10", "9/10"], ["1/2", "-3/10", "4/5"]
    ref = Reference(50)
    xd, pd = ref.hamiltonian_vector_field_mp(
        su2(), theta, ups, I, {"kind": "gravity", "L": Lv, "gamma": gam}, x, pi
    )
    # printed side, exact in sympy
    X = sp.Matrix([sp.Rational(v) for v in x])
    P = sp.Matrix([sp.Rational(v) for v in pi])
    ad = sp.Matrix(3, 3, lambda m, b: sum(X[a] * su.eps(m, a, b) for a in range(3)))
    Ad = (ad).exp()
    Gam = Ad.T * sp.Matrix([sp.Rational(v) for v in gam])
    L = sp.Matrix([sp.Rational(v) for v in Lv])
    dV = sp.Matrix(
        [
            -sum(Gam[a] * su.eps(a, mu, b) * L[b] for a in range(3) for b in range(3))
            for mu in range(3)
        ]
    )
    pp = P + sp.Matrix(xi)
    t = sp.Matrix(tau)
    C1 = 1 - (pp.T * t)[0]
    Phi_inv = (sp.eye(3) - t * pp.T) / C1
    Psi_inv = (sp.eye(3) - pp * t.T) / C1
    dK = sp.Matrix(I).inv() * P
    Om = [
        sum(
            (dK[n] + sum(dV[m] * tau[l] * su.eps(l, m, n) for m in range(3) for l in range(3)))
            * Phi_inv[n, a]
            for n in range(3)
        )
        for a in range(3)
    ]
    pdot = [
        sum(
            (-dV[b] + sum(dK[a] * pp[k] * su.eps(k, a, b) for a in range(3) for k in range(3)))
            * Psi_inv[b, m]
            for b in range(3)
        )
        for m in range(3)
    ]
    with mpmath.workdps(60):
        xv = mpmath.matrix([mpmath.mpf(sp.Rational(v).p) / sp.Rational(v).q for v in x])
        adm = mpmath.matrix(
            [[sum(xv[a] * su.eps(m, a, b) for a in range(3)) for b in range(3)] for m in range(3)]
        )
        A = mpmath.eye(3)
        term = mpmath.eye(3)
        for k in range(1, 80):
            term = term * (-adm) / (k + 1)
            A += term
        Om_ref = A * xd
        e1 = max(abs(Om_ref[i] - sp.N(Om[i], 60)._to_mpmath(200)) for i in range(3))
        e2 = max(abs(pd[i] - sp.N(pdot[i], 60)._to_mpmath(200)) for i in range(3))
    assert e1 < mpmath.mpf(10) ** -40 and e2 < mpmath.mpf(10) ** -40, (e1, e2)
