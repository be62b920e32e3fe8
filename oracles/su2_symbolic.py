"""The SU(2) case study (section cinq) done symbolically with sympy, against our conventions.

Every function builds the paper's printed object (vijf1 ... vijf16) and an *independent*
object from docs/conventions.md -- ``W = [[S, 1], [-1, Upsilon]]`` with
``S_ab = pi_m eps_mab - Theta_ab``, ``Theta_ab = -xi_k eps_kab`` (zeven3),
``Upsilon^mn = tau_l eps_lmn`` -- and returns the residual(s) (sympy expressions that
must simplify to 0). Nothing here is compared against a number produced by the code
under test; the two sides are two routes to the same object.

Conventions used for the independent route (docs/conventions.md):

* ``i_X omega_L = dH`` with ``omega_L = 1/2 theta^T ^ W theta`` reads, with ``X`` the column
  of frame components ``(X^a, X_m)`` and ``dH = (H_b, H^n)`` (``H_b = <dH|e^L_b>``,
  ``H^n = dH/dpi_n``), ``X^T W = dH^T`` (vier4, vier5);
* ``Phi = 1 + S Upsilon``, ``Psi = 1 + Upsilon S = Phi^T``, ``Delta = det Phi`` (vier6, vier7);
* equations of motion ``Omega = (dK + dV Upsilon) Phi^-1``,
  ``dpi/dt = (-dV + dK S) Psi^-1`` as row vectors (vier10, vier11).

The degenerate case uses ``tau = (0, 0, t)`` (the paper's "without loss of generality"),
``pi'_3 = 1/t`` on ``Pi_1`` (vijf6), and names the kinetic gradient ``K^a = dK/dpi_a``
and the potential gradient ``V_a = <dV|e^L_a>`` as free symbols, so the checks hold for
every Hamiltonian ``H = K(pi) + V(g)``.
"""

from __future__ import annotations

import operator
from functools import cache

import sympy as sp

from tstarg.refimpl import exact_sympy

__all__ = [
    "eps",
    "model_matrices",
    "paper_constraints",
    "paper_general_solution",
    "paper_null_vectors",
    "paper_particular_solution",
    "paper_phi_psi",
    "paper_vijf10",
    "residuals_degenerate",
    "residuals_nondegenerate",
    "solve_vector_field",
    "symbols",
]


def eps(a: int, b: int, c: int) -> int:
    """Levi-Civita symbol on indices 0..2: the structure constants ``f^a_bc`` of su(2)."""
    try:  # integers only: sp.LeviCivita would sympify (evaluate) strings
        idx = [operator.index(i) for i in (a, b, c)]
    except TypeError:
        raise ValueError(f"eps takes three integer indices, got {(a, b, c)!r:.80}") from None
    return int(sp.LeviCivita(*idx))


@cache
def symbols() -> dict:
    """The symbols of the case study: ``pi``, ``xi``, ``tau`` (vectors), ``t`` (|tau| in the
    degenerate case), ``K``/``V`` gradients, ``zeta1, zeta2``, and a symmetric ``Iinv``."""
    pi = sp.Matrix(sp.symbols("pi1:4", real=True))
    xi = sp.Matrix(sp.symbols("xi1:4", real=True))
    tau = sp.Matrix(sp.symbols("tau1:4", real=True))
    t = sp.Symbol("t", nonzero=True, real=True)
    Kg = sp.Matrix(sp.symbols("K1:4", real=True))
    Vg = sp.Matrix(sp.symbols("V1:4", real=True))
    zeta = sp.symbols("zeta1:3", real=True)
    ii = sp.symbols("i11 i12 i13 i22 i23 i33", real=True)
    Iinv = sp.Matrix([[ii[0], ii[1], ii[2]], [ii[1], ii[3], ii[4]], [ii[2], ii[4], ii[5]]])
    return {"pi": pi, "xi": xi, "tau": tau, "t": t, "K": Kg, "V": Vg, "zeta": zeta, "Iinv": Iinv}


def model_matrices(pi: sp.Matrix, xi: sp.Matrix, tau: sp.Matrix) -> dict:
    """``S, Upsilon, Theta, W, Phi, Psi`` from docs/conventions.md (independent of section cinq)."""
    Theta = sp.Matrix(3, 3, lambda a, b: -sum(xi[k] * eps(k, a, b) for k in range(3)))
    S = sp.Matrix(3, 3, lambda a, b: sum(pi[m] * eps(m, a, b) for m in range(3))) - Theta
    U = sp.Matrix(3, 3, lambda m, n: sum(tau[l] * eps(l, m, n) for l in range(3)))
    W = sp.BlockMatrix([[S, sp.eye(3)], [-sp.eye(3), U]]).as_explicit()
    Phi = sp.eye(3) + S * U
    Psi = sp.eye(3) + U * S
    return {"Theta": Theta, "S": S, "U": U, "W": W, "Phi": Phi, "Psi": Psi}


def paper_phi_psi(pi: sp.Matrix, xi: sp.Matrix, tau: sp.Matrix) -> dict:
    """Section cinq's explicit ``Phi_a^n = C1 delta + tau_a pi'^n``, ``Psi = C1 delta + pi' tau^T``,
    their printed inverses ``(delta - tau pi'^T)/C1``, ``(delta - pi' tau^T)/C1``, and ``C1 = 1 - pi'.tau``."""
    pp = pi + xi
    C1 = 1 - (pp.T * tau)[0]
    return {
        "pp": pp,
        "C1": C1,
        "Phi": C1 * sp.eye(3) + tau * pp.T,
        "Psi": C1 * sp.eye(3) + pp * tau.T,
        "Phi_inv": (sp.eye(3) - tau * pp.T) / C1,
        "Psi_inv": (sp.eye(3) - pp * tau.T) / C1,
    }


def _zero(expr) -> bool:
    return sp.simplify(sp.expand(exact_sympy(expr, "expr"))) == 0  # strings parsed, never evaluated


def _mat_zero(M) -> bool:
    if not isinstance(M, sp.MatrixBase):
        raise TypeError(f"_mat_zero takes a sympy matrix, got {type(M).__name__}")
    return all(_zero(v) for v in M)


def residuals_nondegenerate() -> dict[str, bool]:
    """Checks of vijf1 -- vijf5 and Delta = C1^2 for general ``xi``, ``tau``, ``pi`` (True = holds).

    * ``vijf1``: ``S = pi'_k eps_kab`` (the printed top-left block) equals ``pi.f - Theta``;
    * ``phi_psi``: the printed ``Phi``, ``Psi`` equal ``1 + S U``, ``1 + U S``;
    * ``inverses``: the printed inverses times ``Phi``, ``Psi`` give the identity;
    * ``delta``: ``det Phi = C1^2``;
    * ``vijf2``, ``vijf3``: the printed ``X^a C1``, ``X_m C1`` satisfy ``X^T W = dH^T`` times C1;
    * ``vijf4``: the printed equations of motion (general symmetric ``I^-1``) equal the
      docs/conventions.md row forms with ``Phi^-1``, ``Psi^-1`` computed by sympy;
    * ``vijf5``: for ``V = 0``, ``dpi_m/dt = Omega^a pi'_b eps_bam`` equals vier11.
    """
    s = symbols()
    pi, xi, tau, Kg, Vg, Iinv = s["pi"], s["xi"], s["tau"], s["K"], s["V"], s["Iinv"]
    M = model_matrices(pi, xi, tau)
    P = paper_phi_psi(pi, xi, tau)
    pp, C1 = P["pp"], P["C1"]
    out: dict[str, bool] = {}
    S_paper = sp.Matrix(3, 3, lambda a, b: sum(pp[k] * eps(k, a, b) for k in range(3)))
    U_paper = sp.Matrix(3, 3, lambda m, n: sum(tau[l] * eps(l, m, n) for l in range(3)))
    W_paper = sp.BlockMatrix([[S_paper, sp.eye(3)], [-sp.eye(3), U_paper]]).as_explicit()
    out["vijf1"] = _mat_zero(W_paper - M["W"])
    out["phi_psi"] = _mat_zero(P["Phi"] - M["Phi"]) and _mat_zero(P["Psi"] - M["Psi"])
    out["inverses"] = _mat_zero(
        sp.expand(M["Phi"] * (sp.eye(3) - tau * pp.T)) - C1 * sp.eye(3)
    ) and _mat_zero(sp.expand(M["Psi"] * (sp.eye(3) - pp * tau.T)) - C1 * sp.eye(3))
    out["delta"] = _zero(M["Phi"].det() - C1**2)
    # vijf2 / vijf3: C1 X from the printed formulas
    Xu = sp.Matrix(
        [
            Kg[a]
            - pp[a] * (tau.T * Kg)[0]
            - sum(eps(a, m, n) * Vg[m] * tau[n] for m in range(3) for n in range(3))
            for a in range(3)
        ]
    )
    Xd = sp.Matrix(
        [
            -Vg[m]
            + tau[m] * (pp.T * Vg)[0]
            - sum(eps(m, a, b) * Kg[a] * pp[b] for a in range(3) for b in range(3))
            for m in range(3)
        ]
    )
    lhs = (sp.Matrix.vstack(Xu, Xd).T * M["W"]).T
    rhs = C1 * sp.Matrix.vstack(Vg, Kg)
    res = sp.expand(lhs - rhs)
    out["vijf2"] = _mat_zero(res[3:, 0])  # the dpi-block of X^T W involves X^a (+ X_m U)
    out["vijf3"] = _mat_zero(res[:3, 0])
    # vijf4 with K = 1/2 pi.Iinv pi, generic V gradient
    dK = Iinv * pi
    Phi_inv = M["Phi"].inv()
    Psi_inv = M["Psi"].inv()
    Om_conv = ((dK.T + Vg.T * M["U"]) * Phi_inv).T
    pd_conv = ((-Vg.T + dK.T * M["S"]) * Psi_inv).T
    Om_paper = sp.Matrix(
        [
            sum(
                (dK[n] + sum(Vg[m] * tau[l] * eps(l, m, n) for m in range(3) for l in range(3)))
                * P["Phi_inv"][n, a]
                for n in range(3)
            )
            for a in range(3)
        ]
    )
    pd_paper = sp.Matrix(
        [
            sum(
                (-Vg[b] + sum(dK[a] * pp[k] * eps(k, a, b) for a in range(3) for k in range(3)))
                * P["Psi_inv"][b, m]
                for b in range(3)
            )
            for m in range(3)
        ]
    )
    out["vijf4"] = _mat_zero(sp.together(Om_conv - Om_paper)) and _mat_zero(
        sp.together(pd_conv - pd_paper)
    )
    Om0 = (dK.T * Phi_inv).T
    pd0_conv = (dK.T * M["S"] * Psi_inv).T
    pd0_paper = sp.Matrix(
        [sum(Om0[a] * pp[b] * eps(b, a, m) for a in range(3) for b in range(3)) for m in range(3)]
    )
    out["vijf5"] = _mat_zero(sp.together(pd0_conv - pd0_paper))
    return out


# --------------------------------------------------------------------- degenerate case
def _degenerate_setup() -> dict:
    s = symbols()
    t = s["t"]
    tau = sp.Matrix([0, 0, t])
    xi = s["xi"]
    pi = sp.Matrix([s["pi"][0], s["pi"][1], 1 / t - xi[2]])  # vijf6: pi_3 = 1/tau - xi_3
    M = model_matrices(pi, xi, tau)
    pp = pi + xi
    return {"t": t, "tau": tau, "xi": xi, "pi": pi, "pp": pp, **M}


def paper_vijf10() -> sp.Matrix:
    """The printed 6x6 matrix of ``omega_L|1`` (vijf10) in terms of ``pi'_1, pi'_2, t``."""
    d = _degenerate_setup()
    t, p1, p2 = d["t"], d["pp"][0], d["pp"][1]
    return sp.Matrix(
        [
            [0, 1 / t, -p2, 1, 0, 0],
            [-1 / t, 0, p1, 0, 1, 0],
            [p2, -p1, 0, 0, 0, 1],
            [-1, 0, 0, 0, t, 0],
            [0, -1, 0, -t, 0, 0],
            [0, 0, -1, 0, 0, 0],
        ]
    )


def paper_null_vectors() -> list[sp.Matrix]:
    """``Z^1, Z^2`` of vijf12 as columns ``(X^1, X^2, X^3, X_1, X_2, X_3)``."""
    d = _degenerate_setup()
    t, p1, p2 = d["t"], d["pp"][0], d["pp"][1]
    return [sp.Matrix([1, 0, 0, 0, 1 / t, -p2]), sp.Matrix([0, 1, 0, -1 / t, 0, p1])]


def paper_constraints(Kg=None, Vg=None) -> dict:
    """``C21, C22`` (vijf13) and ``C23`` (after vijf14) in the gradients ``K^a``, ``V_a``."""
    d = _degenerate_setup()
    s = symbols()
    Kg = s["K"] if Kg is None else Kg
    Vg = s["V"] if Vg is None else Vg
    p = d["pp"]
    return {
        "C21": p[1] * Kg[2] - p[2] * Kg[1] - Vg[0],
        "C22": p[2] * Kg[0] - p[0] * Kg[2] - Vg[1],
        "C23": p[0] * Kg[1] - p[1] * Kg[0] - Vg[2],
    }


def paper_particular_solution() -> sp.Matrix:
    """``X_P`` of vijf14."""
    s = symbols()
    Kg = s["K"]
    return sp.Matrix([Kg[0], Kg[1], Kg[2], 0, 0, paper_constraints()["C23"]])


def paper_general_solution() -> sp.Matrix:
    """``X_G`` of vijf15 with the multipliers ``zeta1, zeta2``."""
    d = _degenerate_setup()
    z1, z2 = symbols()["zeta"]
    t, p1, p2 = d["t"], d["pp"][0], d["pp"][1]
    return (
        z1 * sp.Matrix([1, 0, 0, 0, 1 / t, -p2])
        + z2 * sp.Matrix([0, 1, 0, -1 / t, 0, p1])
        + paper_particular_solution()
    )


def solve_vector_field(W: sp.Matrix, dH: sp.Matrix) -> sp.Matrix:
    """The unique ``X`` with ``X^T W = dH^T`` where ``W`` is invertible (vier4)."""
    return W.T.LUsolve(dH)


def residuals_degenerate() -> dict[str, bool]:
    """Checks of vijf6 -- vijf16 against the docs/conventions.md matrix ``W`` on ``Pi_1`` (True = holds).

    * ``vijf6``: ``C1 = 1 - pi'.tau`` vanishes at ``pi_3 = 1/t - xi_3``;
    * ``vijf7``: the push-forward of ``j_1`` (Jacobian of ``pi_3 = const``) has ``X_3 = 0``;
    * ``vijf9``: the pull-back ``j_1^* omega_L`` is ``W`` with the ``dpi_3`` row and column deleted
      (rank 4 on the 5-manifold);
    * ``vijf10``: the printed matrix equals ``W`` restricted to ``Pi_1``;
    * ``vijf11``: the printed component equations equal ``X^T W = dH^T``;
    * ``vijf12``: ``Z^a`` are null (``Z^T W = 0``), independent, and span the kernel (rank W = 4);
    * ``vijf13``: ``<dH|Z^1> = -C21``, ``<dH|Z^2> = -C22`` (so consistency <=> C21 = C22 = 0);
    * ``vijf14``: ``X_P^T W - dH^T = (C21, C22, 0, 0, 0, 0)`` (a solution exactly on M_2);
    * ``vijf15``: ``X_G - X_P`` is in the kernel, and every solution is of that form;
    * ``vijf16``: ``<dC1|X_G> = -t X_G_3`` (only ``X_3`` moves ``C1``), so tangency to M_1 is ``X_3 = 0``.
    """
    d = _degenerate_setup()
    s = symbols()
    t, W = d["t"], d["W"]
    Kg, Vg = s["K"], s["V"]
    dH = sp.Matrix.vstack(Vg, Kg)
    out: dict[str, bool] = {}
    out["vijf6"] = _zero(1 - (d["pp"].T * d["tau"])[0])
    # vijf7: j1(pi1, pi2) = (pi1, pi2, const): Jacobian of the momentum part
    q1, q2 = s["pi"][0], s["pi"][1]
    J = sp.Matrix([d["pi"]]).jacobian([q1, q2])
    out["vijf7"] = J[:2, :] == sp.eye(2) and J[2, 0] == 0 and J[2, 1] == 0
    # vijf9: pull-back with frame Jacobian diag(1_3, J)
    Jfull = sp.diag(sp.eye(3), J)
    pulled = sp.simplify(Jfull.T * W * Jfull)
    deleted = W[:5, :5]
    out["vijf9"] = _mat_zero(pulled - deleted) and pulled.rank(simplify=True) == 4
    out["vijf10"] = _mat_zero(paper_vijf10() - W)
    X = sp.Matrix(sp.symbols("X1:4 Y1:4"))
    comp = (X.T * W).T - dH
    pp = d["pp"]
    printed = sp.Matrix(
        [
            -(1 / t) * X[1] + pp[1] * X[2] - X[3] - Vg[0],
            (1 / t) * X[0] - pp[0] * X[2] - X[4] - Vg[1],
            -pp[1] * X[0] + pp[0] * X[1] - X[5] - Vg[2],
            X[0] - t * X[4] - Kg[0],
            X[1] + t * X[3] - Kg[1],
            X[2] - Kg[2],
        ]
    )
    out["vijf11"] = _mat_zero(comp - printed)
    Z = paper_null_vectors()
    out["vijf12"] = (
        all(_mat_zero(z.T * W) for z in Z)
        and sp.Matrix.hstack(*Z).rank() == 2
        and W.rank(simplify=True) == 4
    )
    C = paper_constraints()
    out["vijf13"] = _zero((dH.T * Z[0])[0] + C["C21"]) and _zero((dH.T * Z[1])[0] + C["C22"])
    XP = paper_particular_solution()
    out["vijf14"] = _mat_zero((XP.T * W).T - dH - sp.Matrix([C["C21"], C["C22"], 0, 0, 0, 0]))
    XG = paper_general_solution()
    kern = sp.Matrix.hstack(*W.nullspace(simplify=True))
    out["vijf15"] = (
        _mat_zero((XG - XP).T * W) and sp.Matrix.hstack(kern, *Z).rank(simplify=True) == 2
    )
    C1 = 1 - (pi_full_prime(d).T * d["tau"])[0]
    # dC1 in frame components: C1 depends on pi only; d/dpi_3 (1 - t (pi3 + xi3)) = -t
    p3 = sp.Symbol("p3")
    C1_free = 1 - t * (p3 + d["xi"][2])
    out["vijf16"] = _zero(sp.diff(C1_free, p3) * XG[5] + t * XG[5]) and C1 == 0
    return out


def pi_full_prime(d: dict) -> sp.Matrix:
    return d["pi"] + d["xi"]
