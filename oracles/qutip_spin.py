"""qutip's spin picture of the SU(2) body momenta, derived from our sign conventions.

Mapping (twee9, drie3). The Lie-Poisson bracket of the body momenta is
``{pi_a, pi_b} = -pi_k eps_kab`` (twee9 with ``f^k_ab = eps_kab``). Quantisation
``[A, B] = i {A, B}`` (hbar = 1) asks for operators with ``[P_a, P_b] = -i eps_kab P_k``.
qutip's spin operators obey ``[J_a, J_b] = i eps_abc J_c``, so ``P_a = -J_a``:
``[-J_a, -J_b] = i eps_abc J_c = -i eps_kab (-J_k)``. With ``dA/dt = {A, H}`` classically
and ``dA/dt = i [H, A]`` in the Heisenberg picture, ``H = K(pi)`` becomes ``K(-J)``.

With ``Theta = -xi.f`` (zeven3) and ``Upsilon = 0`` the bracket is
``{pi_a, pi_b} = -(pi_k + xi_k) eps_kab`` (drie3, drie8): the shifted momenta
``pi' = pi + xi`` are Lie-Poisson, so ``pi <-> -J - xi``.

Consequences checked here:

* ``H = b.pi`` (linear): ``d<P>/dt = <P> x b`` exactly for every spin ``j`` (Ehrenfest
  is exact for linear Hamiltonians); the classical flow is the rotation
  ``pi(t) = exp(-t [b]_x) pi(0)`` (``dpi/dt = pi x b``). With Theta: ``pi'(t)`` rotates.
* rigid body ``H = 1/(2j) sum P_a^2 / I_a`` on a spin-``j`` coherent state: ``<P>/j``
  follows the unit-sphere Euler flow (oracles.closed_forms, elliptic functions) with an
  error ``O(1/j)`` at fixed time.
* attitude: ``Omega = g^-1 dg/dt`` (docs/conventions.md) in the spin-``j`` representation
  ``E_a = -i J_a`` gives ``d g/dt = g (-i Omega(t).J)``, so ``g(t)^-1`` is qutip's propagator
  of the body-frame Hamiltonian ``H(t) = -Omega(t).J``. For spin 1/2 (``E_a = -(i/2) sigma_a``)
  this is the matrix of docs/conventions.md.
"""

from __future__ import annotations

import matplotlib
import matplotlib.pyplot as plt
import mpmath
import numpy as np
import qutip
from scipy.integrate import solve_ivp
from scipy.special import ellipj

from .closed_forms import rigid_body_solution
from .float_judge import expm

__all__ = [
    "adjoint_from_spin_half",
    "attitude_classical",
    "attitude_propagator",
    "bloch_plot",
    "classical_unit_rigid_body",
    "commutator_defect",
    "linear_flow_error",
    "momentum_operators",
    "rep_defect",
    "rigid_body_expectation",
]


def momentum_operators(j: float, xi=(0.0, 0.0, 0.0)) -> list:
    """``P_a = -J_a - xi_a`` (spin ``j``): the quantum body momenta of our conventions."""
    if not (2 * j == int(2 * j) and j > 0):
        raise ValueError(f"j must be a positive half-integer, got {j!r}")
    one = qutip.qeye(int(2 * j + 1))
    return [-qutip.jmat(j, k) - float(xi[i]) * one for i, k in enumerate("xyz")]


def commutator_defect(j: float, xi=(0.0, 0.0, 0.0), sign: int = -1) -> float:
    """``max_ab || [P_a, P_b] - i {pi_a, pi_b}(P) ||`` with ``{pi_a, pi_b} = -(pi_k + xi_k) eps_kab``.

    ``sign = -1`` is our mapping ``P = -J - xi``; ``sign = +1`` (``P = +J - xi``) is the
    wrong-sign control, which must fail.
    """
    one = qutip.qeye(int(2 * j + 1))
    P = (
        [sign * qutip.jmat(j, k) - float(xi[i]) * one for i, k in enumerate("xyz")]
        if sign == 1
        else momentum_operators(j, xi)
    )
    worst = 0.0
    for a in range(3):
        for b in range(3):
            lhs = P[a] * P[b] - P[b] * P[a]
            rhs = 0 * one
            for k in range(3):
                e = _eps(k, a, b)
                if e:
                    rhs = rhs + (-1j * e) * (P[k] + float(xi[k]) * one)
            worst = max(worst, (lhs - rhs).norm("max"))
    return worst


def _eps(a, b, c) -> int:
    return ((a - b) * (b - c) * (c - a)) // 2


def _cross_matrix(b) -> np.ndarray:
    b = np.asarray(b, dtype=float)
    return np.array([[0, -b[2], b[1]], [b[2], 0, -b[0]], [-b[1], b[0], 0]])


def linear_flow_error(
    j: float, b, xi, times, theta: float = 0.7, phi: float = 0.3
) -> tuple[float, float]:
    """``H = b.pi`` with the Theta shift: max over ``times`` of ``|<P>(t) - pi_cl(t)|``, and the scale ``|pi|``.

    Quantum: ``H = b.P`` with ``P = -J - xi``, exact exponentiation ``exp(-i H t)`` (qutip ``Qobj.expm``).
    Classical: ``dpi/dt = (pi + xi) x b`` (drie5/drie6 with Theta = -xi.f), i.e.
    ``pi'(t) = expm(-t [b]_x) pi'(0)``.
    """
    P = momentum_operators(j, xi)
    H = sum(float(b[a]) * P[a] for a in range(3))
    psi0 = qutip.spin_coherent(j, theta, phi)
    pi0 = np.array([qutip.expect(P[a], psi0) for a in range(3)])
    worst = 0.0
    for t in times:
        psi = (-1j * H * float(t)).expm() * psi0
        q = np.array([qutip.expect(P[a], psi) for a in range(3)])
        cl = expm(-float(t) * _cross_matrix(b)) @ (pi0 + np.asarray(xi, float)) - np.asarray(
            xi, float
        )
        worst = max(worst, float(np.max(np.abs(q - cl))))
    return worst, float(np.max(np.abs(pi0 + np.asarray(xi, float)))) + float(np.max(np.abs(xi)))


def classical_unit_rigid_body(inertia_diag, n0, times, dps: int = 30) -> np.ndarray:
    """Unit-sphere Euler flow ``dpi/dt = pi x I^-1 pi`` from ``n0`` by the elliptic closed form."""

    with mpmath.workdps(dps):
        sol = rigid_body_solution(inertia_diag, [mpmath.mpf(float(v)) for v in n0])
        return np.array([[float(v) for v in sol(mpmath.mpf(float(t)))] for t in times])


def rigid_body_expectation(j: float, inertia_diag, times, theta: float = 0.9, phi: float = 0.4):
    """``<P>(t)/j`` for ``H = 1/(2j) sum P_a^2/I_a`` from a spin coherent state, and the classical
    unit-sphere solution from ``<P>(0)/|<P>(0)|`` (so the comparison does not depend on qutip's
    coherent-state angle convention). Returns ``(quantum, classical)`` arrays ``(len(times), 3)``."""
    P = momentum_operators(j)
    H = sum((1.0 / (2 * j * float(inertia_diag[a]))) * P[a] * P[a] for a in range(3))
    psi0 = qutip.spin_coherent(j, theta, phi)
    q = []
    for t in times:
        psi = (-1j * H * float(t)).expm() * psi0
        q.append([qutip.expect(P[a], psi) / j for a in range(3)])
    q = np.array(q)
    n0 = q[0] / np.linalg.norm(q[0]) if float(times[0]) == 0 else None
    if n0 is None:
        raise ValueError("times must start at 0")
    return q, classical_unit_rigid_body(inertia_diag, n0, times)


def attitude_propagator(
    j: float, inertia_diag, pi0, t_end: float, *, tol: float = 1e-13
) -> qutip.Qobj:
    """``g(t_end)`` in the spin-``j`` representation: the inverse of qutip's propagator of
    ``H(t) = -Omega(t).J`` with ``Omega = I^-1 pi(t)`` from the elliptic closed form
    (float64 evaluation of ``sn, cn, dn`` through ``scipy.special.ellipj``)."""

    with mpmath.workdps(30):
        sol = rigid_body_solution(inertia_diag, [mpmath.mpf(float(v)) for v in pi0])
        A, B, C, w, m, u0 = (float(v) for v in (sol.A, sol.B, sol.C, sol.w, sol.m, sol.u0))
    p, q, r = sol.perm
    amp = {p: A, q: B, r: C}
    kind = {p: 1, q: 0, r: 2}  # ellipj returns (sn, cn, dn, ph)

    def coef(a):
        def f(t):
            return -ellipj(w * t + u0, m)[kind[a]] * amp[a] / float(inertia_diag[a])

        return f

    H = qutip.QobjEvo([[qutip.jmat(j, k), coef(a)] for a, k in enumerate("xyz")])
    U = qutip.propagator(H, t_end, options={"atol": tol * 1e-2, "rtol": tol, "nsteps": 10**6})
    return U.dag()


def attitude_classical(inertia_diag, pi0, t_end: float, *, rtol: float = 1e-13) -> np.ndarray:
    """``g(t_end)`` as a 2x2 SU(2) matrix from ``dg/dt = g Omega^a E_a``, ``E_a = -(i/2) sigma_a``,
    integrated by scipy's DOP853 (an integrator independent of qutip) along the closed-form ``Omega``."""

    with mpmath.workdps(30):
        sol = rigid_body_solution(inertia_diag, [mpmath.mpf(float(v)) for v in pi0])
    sig = [
        np.array([[0, 1], [1, 0]], complex),
        np.array([[0, -1j], [1j, 0]]),
        np.array([[1, 0], [0, -1]], complex),
    ]
    E = [-0.5j * s for s in sig]

    A, B, C, w, m, u0 = (float(v) for v in (sol.A, sol.B, sol.C, sol.w, sol.m, sol.u0))
    p, q, r = sol.perm

    def pi_t(t):
        sn, cn, dn, _ = ellipj(w * t + u0, m)
        out = np.empty(3)
        out[p], out[q], out[r] = A * cn, B * sn, C * dn
        return out

    def rhs(t, y):
        g = (y[0:4] + 1j * y[4:8]).reshape(2, 2)
        Om = pi_t(t) / np.asarray(inertia_diag, float)
        d = g @ sum(Om[a] * E[a] for a in range(3))
        d = d.reshape(4)
        return np.concatenate([d.real, d.imag])

    y0 = np.concatenate([np.eye(2).reshape(4), np.zeros(4)])
    res = solve_ivp(rhs, (0.0, float(t_end)), y0, method="DOP853", rtol=rtol, atol=rtol * 1e-2)
    y = res.y[:, -1]
    return (y[:4] + 1j * y[4:]).reshape(2, 2)


def adjoint_from_spin_half(g: np.ndarray) -> np.ndarray:
    """``Ad(g)^m_b``: ``g E_b g^-1 = Ad(g)^m_b E_m`` with ``tr(E_a E_b) = -delta_ab / 2``."""
    sig = [
        np.array([[0, 1], [1, 0]], complex),
        np.array([[0, -1j], [1j, 0]]),
        np.array([[1, 0], [0, -1]], complex),
    ]
    E = [-0.5j * s for s in sig]
    gi = np.linalg.inv(g)
    return np.array(
        [[(-2 * np.trace(E[m] @ g @ E[b] @ gi)).real for b in range(3)] for m in range(3)]
    )


def rep_defect(U1: qutip.Qobj, Ad: np.ndarray) -> float:
    """``max_b || U J_b U^-1 - Ad^m_b J_m ||`` for a spin-1 matrix ``U``: is ``U`` the image of the
    same group element whose adjoint matrix is ``Ad`` (``g E_b g^-1 = Ad^m_b E_m`` in every rep)."""
    J = [qutip.jmat(1, k) for k in "xyz"]
    Ui = U1.inv() if hasattr(U1, "inv") else qutip.Qobj(np.linalg.inv(U1.full()))
    worst = 0.0
    for b in range(3):
        lhs = U1 * J[b] * Ui
        rhs = sum(float(Ad[m, b]) * J[m] for m in range(3))
        worst = max(worst, (lhs - rhs).norm("max"))
    return worst


def bloch_plot(path, classical: np.ndarray, quantum: np.ndarray, title: str) -> None:
    """Classical (line, normalised to the unit sphere) and quantum (points, ``<P>/j``, inside the
    sphere as coherence is lost) trajectories on a Bloch sphere (matplotlib Agg)."""

    matplotlib.use("Agg")

    fig = plt.figure(figsize=(5, 5))
    ax = fig.add_subplot(projection="3d")
    u, v = np.mgrid[0 : 2 * np.pi : 30j, 0 : np.pi : 15j]
    ax.plot_wireframe(
        np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.85", linewidth=0.4
    )
    c = classical / np.linalg.norm(classical, axis=1, keepdims=True)
    ax.plot(c[:, 0], c[:, 1], c[:, 2], "b-", label="classical (closed form)")
    ax.plot(quantum[:, 0], quantum[:, 1], quantum[:, 2], "r.", markersize=4, label="quantum <P>/j")
    ax.set_box_aspect((1, 1, 1))
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=7, loc="lower left")
    fig.savefig(path, dpi=90)
    plt.close(fig)
