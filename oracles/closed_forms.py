"""Closed-form solutions and first integrals, stated in our conventions (docs/conventions.md).

Free rigid body (twee13, twee14, twee18 with L = 0; so(3) = su(2), f^m_ab = eps_mab)
----------------------------------------------------------------------------------
``dpi/dt = pi x Omega``, ``Omega = I^-1 pi``, ``I = diag(I_1, I_2, I_3)``. Componentwise
``dpi_i/dt = c_i pi_j pi_k`` for every permutation ``(i, j, k)``, with
``c_1 = 1/I_3 - 1/I_2``, ``c_2 = 1/I_1 - 1/I_3``, ``c_3 = 1/I_2 - 1/I_1`` (``sum c_i = 0``).

Ansatz, for a permutation ``(p, q, r)`` of the axes and ``tau = w t + u0``::

    pi_p = A cn(tau | m),   pi_q = B sn(tau | m),   pi_r = C dn(tau | m).

With ``cn' = -sn dn``, ``sn' = cn dn``, ``dn' = -m sn cn`` the equations become
``-A w = c_p B C``, ``B w = c_q C A``, ``-C m w = c_r A B``, whence

* ``A^2 = (c_q pi_p^2 - c_p pi_q^2) / c_q`` and ``C^2 = (c_q pi_r^2 - c_r pi_q^2) / c_q``
  (both conserved: ``d/dt (c_q pi_p^2 - c_p pi_q^2) = 0``);
* ``w^2 = -c_p c_q C^2``, ``m = c_r A^2 / (c_p C^2)``, ``B = c_q C A / w``;
* ``u0 = F(phi0 | m)`` with ``(sin phi0, cos phi0) = (pi_q(0)/B, pi_p(0)/A)`` (the amplitude).

The permutation is the one for which ``A^2, C^2, w^2 > 0`` and ``0 <= m <= 1``: ``pi_r``
(the ``dn`` axis) is the axis the body tumbles around and never changes sign.
``m = 1`` is the separatrix (``sn = tanh``, ``cn = dn = sech``): the orbit through the
unstable rotation about the middle axis. ``mpmath.ellipfun`` evaluates sn, cn, dn.

DETEST problem B5 (Hull, Enright, Fellen, Sedgwick, "Comparing numerical methods for
ordinary differential equations", SIAM J. Numer. Anal. 9 (1972) 603-637):
``y1' = y2 y3``, ``y2' = -y1 y3``, ``y3' = -0.51 y1 y2``, ``y(0) = (0, 1, 1)``, exact
solution ``y = (sn, cn, dn)(x | 0.51)``. It is a free rigid body after the scaling
``y_i = s_i pi_i`` with ``s = (1/sqrt(1.51), 1, 1)``: then ``c = (sqrt(1.51), -1, -0.51)/sqrt(1.51)``
and ``1/I = (a3 + c_2, a3 - c_1, a3)`` for any ``a3`` making them positive (adding a multiple of
the Casimir ``|pi|^2`` to ``H`` does not change ``dpi/dt``); we take ``a3 = 1 + c_1``.

Heavy tops (twee15 -- twee18, corrected twee17), body variables ``(Gamma, pi)``
------------------------------------------------------------------------------
``dpi/dt = pi x Omega + L x Gamma``, ``dGamma/dt = Gamma x Omega``, ``V = -(Gamma | L)``.
Integrals (each checked to be conserved along the reference vector field):

* energy ``H = 1/2 pi.I^-1 pi - Gamma.L``; Casimirs ``|Gamma|^2``, ``pi.Gamma``;
* Lagrange (``I_1 = I_2``, ``L = (0, 0, l)``): ``pi_3``;
* Kovalevskaya (``I = diag(2a, 2a, a)``, ``L = (l, 0, 0)``):
  ``|(Omega_1 + i Omega_2)^2 + (l/a) (Gamma_1 + i Gamma_2)|^2``. Derivation in our signs:
  ``z = Omega_1 + i Omega_2``, ``w = Gamma_1 + i Gamma_2`` obey ``2 z' = -i Omega_3 z - i (l/a) Gamma_3``
  and ``w' = -i Omega_3 w + i Gamma_3 z``, so ``(z^2 + (l/a) w)' = -i Omega_3 (z^2 + (l/a) w)``;
* Goryachev-Chaplygin (``I = diag(4a, 4a, a)``, ``L = (l, 0, 0)``, on ``pi.Gamma = 0``):
  ``G = pi_3 (pi_1^2 + pi_2^2) + 4 a l pi_1 Gamma_3``, with ``dG/dt = a l pi_2 (pi.Gamma)`` in
  general (so it is an integral exactly on the level ``pi.Gamma = 0``).

(Classical references: Golubev, *Lectures on integration of the equations of motion of a
rigid body about a fixed point*, 1953; Borisov & Mamaev, *Rigid body dynamics*, 2001 --
stated here in the signs of twee18 and the corrected twee17.)
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import mpmath
import sympy as sp

from tstarg.refimpl import exact_sympy, su2
from tstarg.refimpl.reference import Reference

__all__ = [
    "DETEST_B5_M",
    "HEAVY_TOPS",
    "EllipticRigidBody",
    "detest_b5",
    "detest_b5_exact",
    "euler_rhs",
    "heavy_top_integrals",
    "integral_rates",
    "rigid_body_solution",
]


def DETEST_B5_M() -> mpmath.mpf:
    """The B5 parameter 0.51, created at the current precision."""
    return mpmath.mpf(51) / 100


def euler_rhs(inertia_diag, pi):
    """``pi x (I^-1 pi)`` (mpmath): the free rigid body in our conventions."""
    a = [1 / mpmath.mpf(v) for v in inertia_diag]
    Om = [a[i] * pi[i] for i in range(3)]
    return [
        pi[1] * Om[2] - pi[2] * Om[1],
        pi[2] * Om[0] - pi[0] * Om[2],
        pi[0] * Om[1] - pi[1] * Om[0],
    ]


@dataclass
class EllipticRigidBody:
    """``pi(t)`` of the free rigid body as Jacobi elliptic functions (see the module docstring)."""

    perm: tuple
    A: mpmath.mpf
    B: mpmath.mpf
    C: mpmath.mpf
    w: mpmath.mpf
    m: mpmath.mpf
    u0: mpmath.mpf

    def __call__(self, t) -> list:
        tau = self.w * t + self.u0
        sn = mpmath.ellipfun("sn", tau, m=self.m)
        cn = mpmath.ellipfun("cn", tau, m=self.m)
        dn = mpmath.ellipfun("dn", tau, m=self.m)
        out = [None] * 3
        p, q, r = self.perm
        out[p], out[q], out[r] = self.A * cn, self.B * sn, self.C * dn
        return out


def rigid_body_solution(inertia_diag, pi0) -> EllipticRigidBody:
    """The closed-form solution through ``pi0`` (current mpmath precision).

    ``inertia_diag``: three positive principal moments, pairwise distinct (for a symmetric
    body the motion is elementary and the elliptic modulus degenerates); ``pi0``: the initial
    body momentum, not on a principal axis of rotation (an equilibrium).
    """
    I = [mpmath.mpf(v) for v in inertia_diag]
    if len(I) != 3 or any(not v > 0 for v in I):
        raise ValueError(f"inertia_diag must be three positive numbers, got {inertia_diag!r}")
    if len({float(v) for v in I}) < 3:
        raise ValueError(
            f"inertia_diag must be pairwise distinct for the elliptic form, got {inertia_diag!r}"
        )
    pi0 = [mpmath.mpf(v) for v in pi0]
    if sum(1 for v in pi0 if v != 0) < 2:
        raise ValueError(
            f"pi0 = {pi0} lies on a principal axis: a steady rotation, not an elliptic orbit"
        )
    a = [1 / v for v in I]
    c = [a[2] - a[1], a[0] - a[2], a[1] - a[0]]
    for p, q, r in itertools.permutations(range(3)):
        if c[q] == 0 or c[p] * c[q] >= 0:
            continue
        A2 = (c[q] * pi0[p] ** 2 - c[p] * pi0[q] ** 2) / c[q]
        C2 = (c[q] * pi0[r] ** 2 - c[r] * pi0[q] ** 2) / c[q]
        if not (A2 > 0 and C2 > 0):
            continue
        m = c[r] * A2 / (c[p] * C2)
        if abs(m - 1) < mpmath.mpf(10) ** (-mpmath.mp.dps + 8):
            m = mpmath.mpf(1)  # the separatrix, up to the rounding of the inputs
        if not (0 <= m <= 1):
            continue
        if pi0[r] == 0:
            continue
        A = mpmath.sqrt(A2)
        C = mpmath.sqrt(C2) * mpmath.sign(pi0[r])
        w = mpmath.sqrt(-c[p] * c[q] * C2)
        B = c[q] * C * A / w
        phi0 = mpmath.atan2(pi0[q] / B, pi0[p] / A)
        u0 = mpmath.ellipf(phi0, m)
        return EllipticRigidBody((p, q, r), A, B, C, w, m, u0)
    raise ValueError(f"no elliptic parametrisation found for I = {inertia_diag}, pi0 = {pi0}")


def detest_b5():
    """B5 as a rigid body: ``(inertia_diag, scale s, pi0)`` with ``y_i = s_i pi_i``, ``y(0) = (0, 1, 1)``."""
    k = mpmath.sqrt(1 + DETEST_B5_M())
    s = [1 / k, mpmath.mpf(1), mpmath.mpf(1)]
    P = s[0] * s[1] * s[2]
    target = [mpmath.mpf(1), mpmath.mpf(-1), -DETEST_B5_M()]
    c = [target[i] * P / s[i] ** 2 for i in range(3)]
    a3 = 1 + c[0]
    a = [a3 + c[1], a3 - c[0], a3]
    inertia = [1 / v for v in a]
    y0 = [0, 1, 1]
    return inertia, s, [mpmath.mpf(y0[i]) / s[i] for i in range(3)]


def detest_b5_exact(x) -> list:
    """The published exact solution of DETEST B5: ``(sn, cn, dn)(x | 0.51)``."""
    return [mpmath.ellipfun(k, x, m=DETEST_B5_M()) for k in ("sn", "cn", "dn")]


def _sym():
    G = sp.Matrix(sp.symbols("Gamma1:4", real=True))
    p = sp.Matrix(sp.symbols("pi1:4", real=True))
    return G, p


def heavy_top_integrals(inertia_diag, L) -> dict:
    """Sympy expressions ``I(Gamma, pi)`` of the integrals valid for this top (see docstring).

    Returns ``{name: (expr, needs_pi_dot_gamma_zero)}``; always ``energy``, ``casimir_gamma``,
    ``casimir_pi_gamma``; ``lagrange``, ``kovalevskaya``, ``goryachev_chaplygin`` when ``I`` and ``L``
    have the required form.
    """
    I = [exact_sympy(v, "inertia_diag entry") for v in inertia_diag]  # strings never evaluated
    Lv = sp.Matrix([exact_sympy(v, "L entry") for v in L])
    G, p = _sym()
    Om = sp.Matrix([p[i] / I[i] for i in range(3)])
    out = {
        "energy": (sp.Rational(1, 2) * (p.T * Om)[0] - (G.T * Lv)[0], False),
        "casimir_gamma": ((G.T * G)[0], False),
        "casimir_pi_gamma": ((p.T * G)[0], False),
    }
    if I[0] == I[1] and Lv[0] == 0 and Lv[1] == 0:
        out["lagrange"] = (p[2], False)
    if I[0] == I[1] == 2 * I[2] and Lv[1] == 0 and Lv[2] == 0:
        c = Lv[0] / I[2]
        re = Om[0] ** 2 - Om[1] ** 2 + c * G[0]
        im = 2 * Om[0] * Om[1] + c * G[1]
        out["kovalevskaya"] = (re**2 + im**2, False)
    if I[0] == I[1] == 4 * I[2] and Lv[1] == 0 and Lv[2] == 0:
        out["goryachev_chaplygin"] = (
            p[2] * (p[0] ** 2 + p[1] ** 2) + 4 * I[2] * Lv[0] * p[0] * G[2],
            True,
        )
    return out


HEAVY_TOPS = {
    "lagrange": {"inertia": (3, 3, 1), "L": (0, 0, 2), "gamma": (0, 0, 1)},
    "kovalevskaya": {"inertia": (2, 2, 1), "L": (1, 0, 0), "gamma": (0, 0, 1)},
    "goryachev_chaplygin": {"inertia": (4, 4, 1), "L": (1, 0, 0), "gamma": (0, 0, 1)},
}


def integral_rates(name: str, x, pi, *, dps: int = 50) -> dict:
    """``dI/dt = grad I . zdot`` for every integral of the heavy top ``HEAVY_TOPS[name]`` at the
    state ``(x, pi)`` (``g = exp(x)``), with ``zdot`` from the reference vector field
    (``Reference(dps).hamiltonian_vector_field_mp``, vier10/vier11 with Theta = Upsilon = 0) and
    ``dGamma/dt`` by the chain rule (``mpmath.diff`` of ``Gamma(x) = Ad(exp x)^T gamma`` along ``xdot``),
    so neither twee17 nor the Euler-Poisson form is assumed.

    Returns ``{integral: (rate, scale)}`` with ``scale = |grad I| |zdot|`` (the size a wrong
    integral's rate would have).
    """

    if name not in HEAVY_TOPS:
        raise ValueError(f"unknown heavy top {name!r}; known: {sorted(HEAVY_TOPS)}")
    top = HEAVY_TOPS[name]
    ref = Reference(dps)
    alg = su2()
    zero = [[0] * 3 for _ in range(3)]
    inertia = [[top["inertia"][i] if i == j else 0 for j in range(3)] for i in range(3)]
    pot = {"kind": "gravity", "L": list(top["L"]), "gamma": list(top["gamma"])}
    xd, pd = ref.hamiltonian_vector_field_mp(alg, zero, zero, inertia, pot, x, pi)
    G, p = _sym()
    out = {}
    with ref._prec():
        F = ref._algebra_mp(alg)
        gam = ref._vec(top["gamma"], 3, "gamma")
        xv = ref._vec(x, 3, "x")
        pv = ref._vec(pi, 3, "pi")

        def Gamma_along(s):
            xs = mpmath.matrix([xv[i] + s * xd[i] for i in range(3)])
            return mpmath.expm(ref.ad(F, xs)).T * gam

        Gv = Gamma_along(0)
        Gd = [mpmath.diff(lambda s, m=m: Gamma_along(s)[m], 0) for m in range(3)]
        for key, (expr, _needs) in heavy_top_integrals(top["inertia"], top["L"]).items():
            grad = [sp.diff(expr, v) for v in list(G) + list(p)]
            fn = sp.lambdify(list(G) + list(p), grad, modules="mpmath")
            gv = fn(*(list(Gv) + list(pv)))
            zdot = Gd + [pd[i] for i in range(3)]
            rate = mpmath.fsum(a * b for a, b in zip(gv, zdot))
            scale = mpmath.sqrt(mpmath.fsum(a**2 for a in gv)) * mpmath.sqrt(
                mpmath.fsum(b**2 for b in zdot)
            )
            out[key] = (rate, scale)
    return out
