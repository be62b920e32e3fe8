"""Checks of section cinq (su(2)): the symbolic case study, its explicit matrices and component
equations, the plane of degenerate points and the Gotay-Nester-Hinds examples (vijf16)."""

from __future__ import annotations

import sympy as sp

from ..gnh_examples import EXAMPLES, check_example
from ..su2_symbolic import residuals_degenerate, residuals_nondegenerate
from . import group_model as gm
from .common import Outcome


def cinq_nondegenerate() -> Outcome:
    r = residuals_nondegenerate()
    bad = [k for k, v in r.items() if not v]
    return Outcome(not bad, None, None, f"failed: {bad}" if bad else "all symbolic identities hold")


def cinq_degenerate() -> Outcome:
    r = residuals_degenerate()
    bad = [k for k, v in r.items() if not v]
    return Outcome(not bad, None, None, f"failed: {bad}" if bad else "all symbolic identities hold")


def cinq_gnh() -> Outcome:
    """vijf16 and the GNH outcome: refimpl.gnh on the paper's SU(2) model reproduces M_1 (C1), the
    secondary set (C21 = C22 = 0 on the final manifold), and a tangent solution of the form vijf15."""
    bad = [k for k in EXAMPLES if not EXAMPLES[k].get("slow") and not check_example(k)[0]]
    return Outcome(
        not bad, None, None, f"failed: {bad}" if bad else "worked examples reproduce their outcomes"
    )


def _cinq_symbols():
    pp = sp.Matrix(sp.symbols("q1:4"))  # pi' = pi + xi
    tau = sp.Matrix(sp.symbols("s1:4"))
    S = sp.Matrix(3, 3, lambda a, b: sum(pp[k] * gm.levi_civita(k, a, b) for k in range(3)))
    U = sp.Matrix(3, 3, lambda m, n: sum(tau[l] * gm.levi_civita(l, m, n) for l in range(3)))
    return pp, tau, S, U


def cinq_explicit_matrices() -> Outcome:
    """Section cinq, exact, symbolic ``pi'``, ``tau``: ``S = pi.f - Theta = pi'_k eps_kab`` for
    ``Theta = -xi_k eps_kab``; the inline ``Phi = C1 1 + tau pi'^T``, ``Psi = C1 1 + pi' tau^T`` equal
    vier6's ``1 + S U``, ``1 + U S``; the relations they obey; ``Delta = C1^2``; the unlabelled display
    of the inverses (``(Phi^-1)_nu^b = (delta - tau_nu pi'^b)/C1``, ``(Psi^-1)^b_nu =
    (delta - pi'^b tau_nu)/C1``) multiplied by ``Phi``, ``Psi`` give the identity; the Killing form
    ``eps^m_an eps^n_bm = -2 delta_ab``."""
    pp, tau, S, U = _cinq_symbols()
    C1 = 1 - (pp.T * tau)[0]
    I3 = sp.eye(3)
    Phi, Psi = I3 + S * U, I3 + U * S
    bad = []
    if not sp.expand(Phi - (C1 * I3 + tau * pp.T)).is_zero_matrix:
        bad.append("Phi")
    if not sp.expand(Psi - (C1 * I3 + pp * tau.T)).is_zero_matrix:
        bad.append("Psi")
    if not sp.expand(Phi * (I3 - tau * pp.T) - C1 * I3).is_zero_matrix:
        bad.append("Phi relation")
    if not sp.expand(Psi * (I3 - pp * tau.T) - C1 * I3).is_zero_matrix:
        bad.append("Psi relation")
    if sp.expand(Phi.det() - C1**2) != 0 or sp.expand(Psi.det() - C1**2) != 0:
        bad.append("Delta")
    Phi_inv = (I3 - tau * pp.T) / C1  # row nu, column beta
    Psi_inv = (I3 - pp * tau.T) / C1  # row beta, column nu
    if (
        not sp.simplify(Phi * Phi_inv - I3).is_zero_matrix
        or not sp.simplify(Phi_inv * Phi - I3).is_zero_matrix
    ):
        bad.append("Phi^-1")
    if (
        not sp.simplify(Psi * Psi_inv - I3).is_zero_matrix
        or not sp.simplify(Psi_inv * Psi - I3).is_zero_matrix
    ):
        bad.append("Psi^-1")
    kill = sp.Matrix(
        3,
        3,
        lambda a, b: sum(
            gm.levi_civita(m, a, n) * gm.levi_civita(n, b, m) for m in range(3) for n in range(3)
        ),
    )
    if kill != -2 * I3:
        bad.append("Killing")
    return Outcome(not bad, None, None, f"failed: {bad}" if bad else "exact, symbolic pi', tau")


def cinq_component_equations() -> Outcome:
    """Unlabelled display of cinq: ``i_X omega_L = dH`` in components,
    ``X^a pi'_k eps_kab - X_b = H_b``, ``X^n + X_m tau_l eps_lmn = H^n``, equals ``X^T W = dH^T`` with
    ``W`` of vijf1 (exact, symbolic)."""
    pp, tau, S, U = _cinq_symbols()
    W = sp.BlockMatrix([[S, sp.eye(3)], [-sp.eye(3), U]]).as_explicit()
    X = sp.Matrix(sp.symbols("X1:4 Y1:4"))
    lhs = (X.T * W).T
    printed = sp.Matrix(
        [
            sum(X[a] * pp[k] * gm.levi_civita(k, a, b) for a in range(3) for k in range(3))
            - X[3 + b]
            for b in range(3)
        ]
        + [
            X[n]
            + sum(X[3 + m] * tau[l] * gm.levi_civita(l, m, n) for m in range(3) for l in range(3))
            for n in range(3)
        ]
    )
    ok = sp.expand(lhs - printed).is_zero_matrix
    return Outcome(bool(ok), None, None, "exact, symbolic X, pi', tau")


def cinq_plane() -> Outcome:
    """'the plane Pi_1 = {1 - pi'.tau = 0} is an algebraic manifold' / 'a two dimensional plane':
    true exactly when ``tau != 0`` (then ``dC1 = -tau != 0``, a smooth plane of dimension 2); for
    ``tau = 0``, ``C1 = 1`` and Pi_1 is empty. Also ``Delta = C1^2`` has ``dDelta = 0`` on Pi_1 (the
    variety ``{Delta = 0}`` is the plane counted twice). Exact; passes when all three hold."""
    pp, tau, _S, _U = _cinq_symbols()
    C1 = 1 - (pp.T * tau)[0]
    grad = sp.Matrix([sp.diff(C1, v) for v in pp])
    g_ok = sp.expand(grad + tau).is_zero_matrix
    empty = sp.simplify(C1.subs({t: 0 for t in tau})) == 1
    D = C1**2
    dD = [sp.diff(D, v) for v in pp]
    # on Pi_1 (q3 = (1 - s1 q1 - s2 q2)/s3)
    on = {pp[2]: (1 - tau[0] * pp[0] - tau[1] * pp[1]) / tau[2]}
    vanish = all(sp.simplify(e.subs(on)) == 0 for e in dD)
    ok = g_ok and empty and vanish
    return Outcome(
        bool(ok),
        None,
        None,
        f"dC1 = -tau {g_ok}; tau = 0 -> empty {empty}; dDelta = 0 on Pi_1 {vanish}",
    )


CHECKS = {
    "cinq_nondegenerate": cinq_nondegenerate,
    "cinq_degenerate": cinq_degenerate,
    "cinq_gnh": cinq_gnh,
    "cinq_explicit_matrices": cinq_explicit_matrices,
    "cinq_component_equations": cinq_component_equations,
    "cinq_plane": cinq_plane,
}
