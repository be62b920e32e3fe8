"""Lie-Poisson splitting for su(2)/so(3) with diagonal inertia, ``Upsilon = 0``, any ``Theta`` and
gravity (Strang, raised by the triple jump to orders 4 and 6).

``H = sum_i H_i + V`` with ``H_i = (pi'_i - xi_i)^2 / 2 I_i`` (``pi' = pi + xi``, drie7, drie10): under
``H_i`` the vectors ``pi'`` and ``Gamma`` rotate about ``e_i`` by ``-Omega_i t`` and
``g -> g exp(t Omega_i e_i)``, exactly; under ``V`` only ``pi`` moves, by ``t L x Gamma``. Each sub-flow is
a Poisson map, so the Casimirs ``|pi'|^2`` or ``|Gamma|^2``, ``pi.Gamma`` (for ``xi = 0``) are kept to
rounding and ``g`` stays on the group (a unit quaternion).
"""

from __future__ import annotations

import numpy as np

from ... import _fast_kernels as _fast
from ..._integrators import triple_jump_weights
from ...model import Model
from .._common import gamma0, quat_matrix, quat_to_x, x_to_quat
from ..base import FixedStep, FlowResult

__all__ = ["INTEGRATORS", "Splitting"]


class Splitting(FixedStep):
    """Strang splitting raised to ``order`` by the triple jump (body system or the full state with the
    group element as a quaternion)."""

    def applies(self, model):
        if not model.su2:
            return False, "Lie-Poisson splitting is written for su(2)/so(3) only"
        if not model.upsilon_zero:
            return False, "Lie-Poisson splitting needs Upsilon = 0"
        if not model.I_diagonal:
            return False, "Lie-Poisson splitting needs a diagonal inertia (principal axes)"
        return True, ""

    def _run(self, model, x0, pi0, t, *, steps, system, observe) -> FlowResult:
        G0 = gamma0(model, x0)
        pi = pi0.copy()
        G = None if G0 is None else G0.copy()
        quat = x_to_quat(x0) if system == "full" else None
        _splitting_integrate(model, pi, G, quat, t, steps, self.order, observe=observe)
        return FlowResult(
            pi=pi,
            Gamma=G,
            x=None if quat is None else quat_to_x(quat),
            quat=quat,
            g=None if quat is None else quat_matrix(quat),
            rebases=np.zeros(pi.shape[1], dtype=int),
        )


def _rot(axis: int, ang, A, B=None):
    """Rotate the rows (3, N) of A (and B) about e_axis by the angle ``ang`` (N,)."""
    i, j = (axis + 1) % 3, (axis + 2) % 3
    c, s = np.cos(ang), np.sin(ang)
    for M in (A, B):
        if M is None:
            continue
        u, v = M[i].copy(), M[j]
        M[i] = c * u - s * v
        M[j] = s * u + c * v


def _qmul_axis(q, axis: int, half):
    """``q <- q * (cos h, sin h e_axis)`` (Hamilton product), q of shape (4, N)."""
    c, s = np.cos(half), np.sin(half)
    e = np.zeros(3)
    e[axis] = 1
    q0, qv = q[0].copy(), q[1:].copy()
    q[0] = c * q0 - s * qv[axis]
    bv = np.zeros_like(qv)
    bv[axis] = s
    cross = np.cross(qv, bv, axis=0)
    q[1:] = q0 * bv + c * qv + cross


def _splitting_integrate(model: Model, pi, Gamma, quat, t, nsteps, order, observe=None):
    """Strang splitting raised to ``order`` by the triple jump; state modified in place."""
    d = np.diag(model.Iinv)
    xi = _fast._su2_theta_to_xi(None if model.theta_zero else model.theta)
    xi = np.zeros(3) if xi is None else xi
    q = pi + xi[:, None]  # pi' = pi + xi (drie7): rotated by the H_i flows
    Lv = model.Lvec
    weights = triple_jump_weights(order)
    h = t / nsteps

    def kin(i, tau):  # noqa: E306
        ang = (
            -d[i] * (q[i] - xi[i]) * tau
        )  # Omega_i = (pi'_i - xi_i)/I_i ; y -> R_i(-Omega_i tau) y
        if quat is not None:
            _qmul_axis(quat, i, -ang / 2)  # g -> g exp(tau Omega_i e_i)
        _rot(i, ang, q, Gamma)

    def pot(tau):
        if Gamma is not None:
            q[:] += tau * np.cross(Lv[:, None], Gamma, axis=0)

    for k in range(nsteps):
        for w in weights:
            tau = w * h
            pot(tau / 2)
            kin(0, tau / 2)
            kin(1, tau / 2)
            kin(2, tau)
            kin(1, tau / 2)
            kin(0, tau / 2)
            pot(tau / 2)
        if observe is not None:
            observe(k + 1, q - xi[:, None], Gamma, None if quat is None else quat_to_x(quat))
    pi[:] = q - xi[:, None]


INTEGRATORS = [Splitting(f"splitting{p}", p, rank=50 + p / 100) for p in (2, 4, 6)]
