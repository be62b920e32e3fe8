"""Checks of section trois (the modified forms): the Liouville forms (twee6, drie1, drie7, drie8),
Darboux (drie9) and the labels (the second drie5 is drie12, erratum)."""

from __future__ import annotations

import mpmath
import sympy as sp

from tstarg.refimpl import su2
from tstarg.refimpl.reference import Reference

from . import group_model as gm
from . import paper
from .common import DPS, Outcome, tolerance, within


def liouville_forms() -> Outcome:
    """twee6, drie1, drie7, drie8: ``-d(pi'_m eps_L^m)`` in holonomic coordinates ``(x, pi)`` equals
    ``B^T W B`` with ``B = diag(phi1(-ad_x), 1)``, ``W = [[pi'.f, 1], [-1, 0]]`` (``pi' = pi + xi``;
    ``xi = 0`` is twee6). The matrix of ``-d theta`` is ``Omega_ij = d_j theta_i - d_i theta_j``."""
    worst = mpmath.mpf(0)
    for xi_s in (("0", "0", "0"), ("0.3", "-0.2", "0.5")):
        with mpmath.workdps(DPS + 15):
            x = [mpmath.mpf(v) for v in gm.X0]
            pi = [mpmath.mpf(v) for v in ("0.5", "-0.3", "0.8")]
            xi = [mpmath.mpf(v) for v in xi_s]
            z0 = x + pi

            def theta(z, xi=xi):
                A = gm.phi1(-gm.ad(z[:3]))
                pp = mpmath.matrix([z[3 + k] + xi[k] for k in range(3)])
                return list(A.T * pp) + [mpmath.mpf(0)] * 3

            J = gm.jacobian(theta, z0, n=6)  # J[i, j] = d theta_i / d z_j
            Om = J - J.T
            A = gm.phi1(-gm.ad(x))
            B = mpmath.zeros(6, 6)
            for i in range(3):
                for j in range(3):
                    B[i, j] = A[i, j]
                B[3 + i, 3 + i] = 1
            W = mpmath.zeros(6, 6)
            for a in range(3):
                for b in range(3):
                    W[a, b] = sum((pi[k] + xi[k]) * gm.levi_civita(k, a, b) for k in range(3))
                W[a, 3 + a], W[3 + a, a] = 1, -1
            worst = max(worst, gm.maxabs(Om - B.T * W * B))
    return Outcome(
        bool(worst <= tolerance()), float(worst), float(tolerance()), "-d theta vs the frame matrix"
    )


def drie9_darboux() -> Outcome:
    """drie9: ``(g^a, p'_mu = p_mu + xi_b L^b_mu(g^-1, g))`` are Darboux coordinates of ``omega_I``:
    the reference Poisson tensor (Theta = -xi.f, Upsilon = 0) pushed to ``(x, p')`` is ``[[0, 1], [-1, 0]]``.
    ``p = phi1(-ad_x)^T pi`` (since ``pi_m = p_n L^n_m(g, e)``)."""
    xi_s = ("1/3", "-1/5", "2/7")
    theta = [
        [-sum(sp.Rational(xi_s[k]) * gm.levi_civita(k, a, b) for k in range(3)) for b in range(3)]
        for a in range(3)
    ]
    pi_s = ("0.5", "-0.3", "0.8")
    P = Reference(DPS + 10).poisson_tensor_mp(
        su2(), theta, [[0] * 3 for _ in range(3)], list(gm.X0), list(pi_s)
    )
    with mpmath.workdps(DPS + 15):
        xi = [mpmath.mpf(sp.Rational(v).p) / sp.Rational(v).q for v in xi_s]
        z0 = [mpmath.mpf(v) for v in gm.X0 + pi_s]

        def newc(z):
            A = gm.phi1(-gm.ad(z[:3]))
            pp = mpmath.matrix([z[3 + k] + xi[k] for k in range(3)])
            return list(z[:3]) + list(A.T * pp)

        J = gm.jacobian(newc, z0, n=6)
        Pn = J * P * J.T
        can = mpmath.zeros(6, 6)
        for i in range(3):
            can[i, 3 + i], can[3 + i, i] = 1, -1
        err = gm.maxabs(Pn - can)
    return within(err, "pushed Poisson tensor vs canonical")


def labels_unique_printed() -> Outcome:
    """The paper's equation labels are unique, as printed."""
    labels = paper.paper_labels()
    dup = sorted({x for x in labels if labels.count(x) > 1})
    return Outcome(not dup, None, None, f"duplicated labels: {dup}")


def labels_unique_corrected() -> Outcome:
    """With the second ``drie5`` (the dpi'/dt equation after drie11) renamed ``drie12``, labels are unique."""
    labels = paper.paper_labels()
    seen, fixed = set(), []
    for lab in labels:
        fixed.append("drie12" if lab == "drie5" and lab in seen else lab)
        seen.add(lab)
    dup = sorted({x for x in fixed if fixed.count(x) > 1})
    i11 = fixed.index("drie11")
    return Outcome(
        not dup and fixed[i11 + 1] == "drie12", None, None, f"duplicated after renaming: {dup}"
    )


CHECKS = {
    "liouville_forms": liouville_forms,
    "drie9_darboux": drie9_darboux,
    "labels_unique_printed": labels_unique_printed,
    "labels_unique_corrected": labels_unique_corrected,
}
