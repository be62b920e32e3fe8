"""Darboux equivalence (semisimple, Theta = -xi.f): the flow of drie4/drie5 (Theta in the bracket)
equals the flow of pi' = pi + xi under drie11/drie12 (untwisted bracket, shifted kinetic energy),
and the flow in the canonical coordinates (x, p') of drie9."""

from __future__ import annotations

import mpmath
import numpy as np

from tests._helpers import mp_digits
from tstarg.refimpl import su2
from tstarg.refimpl.flows import (
    DOP853,
    METHODS,
    NumpyModel,
    gbs_mp,
    integrate_fast,
    reference_trajectory,
)

XI = ["3/10", "-1/5", "1/2"]
I_DIAG = ["1", "13/10", "1/2"]
L_VEC, GAMMA = [0, 0, 1], [0, 0, -1]


def test_theta_flow_equals_shifted_momentum_flow():
    """pi(t) + xi from drie4/drie6 (reference, with gravity) == pi'(t) of drie11/drie12 integrated
    independently (written here: dpi'/dt = pi' x Omega + L x Gamma, Omega = I^-1 (pi' - xi))."""
    alg = su2()
    theta = np.empty((3, 3), dtype=object)
    # Theta_ab = -xi_k eps_kab, exactly (rational strings)
    from fractions import Fraction

    xif = [Fraction(v) for v in XI]
    for a in range(3):
        for b in range(3):
            theta[a, b] = -sum(xif[k] * int(alg.f[k, a, b]) for k in range(3))
    I = [[Fraction(I_DIAG[i]) if i == j else 0 for j in range(3)] for i in range(3)]
    x0, pi0 = ["1/10", "1/5", "0"], ["3/10", "1/5", "3/2"]
    pot = {"kind": "gravity", "L": L_VEC, "gamma": GAMMA}
    zero = [[0] * 3 for _ in range(3)]
    tr = reference_trajectory(alg, theta, zero, I, pot, x0, pi0, [0, 4], dps=30, system="body")
    with mpmath.workdps(45):
        Iinv = [1 / mpmath.mpf(Fraction(v).numerator) * Fraction(v).denominator for v in I_DIAG]
        xim = [mpmath.mpf(v.numerator) / v.denominator for v in xif]

        def F(t, y):
            q, G = y[:3], y[3:]
            W = [Iinv[i] * (q[i] - xim[i]) for i in range(3)]
            cr = lambda a, b: [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
            qW, LG, GW = cr(q, W), cr([mpmath.mpf(v) for v in L_VEC], G), cr(G, W)
            return [qW[i] + LG[i] for i in range(3)] + GW

        y0 = [tr.pi[0][i] + xim[i] for i in range(3)] + list(tr.Gamma[0])
        res = gbs_mp(F, y0, 4, tol=mpmath.mpf(10) ** -40, k=14)
        shifted = [tr.pi[-1][i] + xim[i] for i in range(3)]
        assert mp_digits(shifted, res.y[:3], dps=45) >= 27
        assert mp_digits(tr.Gamma[-1], res.y[3:], dps=45) >= 27


def _A_complex(x):
    """phi1(-ad_x) for su(2) by its Taylor series (entire), valid for complex x (complex-step gradients)."""
    K = np.array(
        [[0, -x[2], x[1]], [x[2], 0, -x[0]], [-x[1], x[0], 0]], dtype=complex
    )  # ad_x = [x]_x
    M = -K
    term = np.eye(3, dtype=complex)
    total = term.copy()
    for k in range(1, 40):
        term = term @ M / (k + 1)
        total = total + term
    return total


def test_theta_flow_equals_canonical_darboux_flow():
    """Canonical coordinates of drie9: with p' = A(x)^T (pi + xi), Hamilton's equations
    xdot = dH/dp', p'dot = -dH/dx for H = 1/2 (A^-T p' - xi) I^-1 (A^-T p' - xi) (drie10, V = 0)
    reproduce the drie4/drie5 flow (fast DOP853 on (x, pi) with Theta = -xi.f)."""
    alg = su2()
    xi = np.array([0.3, -0.2, 0.5])
    theta = -np.einsum("k,kab->ab", xi, alg.f)
    Iinv = np.diag([1.0, 1 / 1.3, 2.0])
    x0, pi0 = np.array([0.1, 0.2, 0.0]), np.array([0.3, 0.2, 1.5])

    def H(x, p):
        q = np.linalg.solve(_A_complex(x).T, p) - xi
        return 0.5 * q @ Iinv @ q

    def rhs(z):
        x, p = z[:3], z[3:]
        h = 1e-30
        dHx = np.array([H(x + 1j * h * e, p.astype(complex)).imag / h for e in np.eye(3)])
        dHp = np.array([H(x.astype(complex), p + 1j * h * e).imag / h for e in np.eye(3)])
        return np.concatenate([dHp, -dHx])

    p0 = _A_complex(x0).real.T @ (pi0 + xi)
    T = 1.0

    def run(N):
        z = np.concatenate([x0, p0])
        for _ in range(N):
            z = DOP853.step(rhs, z, T / N)
        x = z[:3]
        pi = np.linalg.solve(_A_complex(x).real.T, z[3:]) - xi
        return np.concatenate([x, pi])

    can, can2 = run(20), run(40)
    model = NumpyModel(alg, theta, np.zeros((3, 3)), np.linalg.inv(Iinv), None)
    out = integrate_fast(model, METHODS["dop853"], x0[:, None], pi0[:, None], T, 40, system="full")
    direct = np.concatenate([out["x"][:, 0], out["pi"][:, 0]])
    # error model: truncation of the canonical run estimated by Richardson (|can - can2| / (2^8 - 1)) x 10,
    # plus rounding of 40 steps of 12 stages on O(1) numbers: 100 * 40 * 12 * eps
    bound = 10 * np.max(np.abs(can - can2)) / 255 + 100 * 40 * 12 * np.finfo(float).eps
    assert np.max(np.abs(can2 - direct)) <= bound
    assert not np.allclose(can2[:3], x0)  # it moved
