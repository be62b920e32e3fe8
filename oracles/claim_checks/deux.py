"""Checks of section deux (T*G): the frames L(g, h) and R(g, h) (twee1, erratum), the coadjoint action
(twee3), the Maurer-Cartan form, the lifted action, gravity (twee15 -- twee17, erratum) and the Euler
equations (twee13)."""

from __future__ import annotations

import random

import mpmath
import sympy as sp

from tstarg.refimpl import su2
from tstarg.refimpl.reference import Reference

from . import algebras
from . import group_model as gm
from .common import DPS, Outcome, tolerance, within


def twee1_frame_printed() -> Outcome:
    """Printed: ``L^a_b(g, h) = d(gh)^a / dg^b``, so ``e^L_b = L^m_b(g, e) d/dg^m`` would be
    ``d/dg^b`` (the derivative of ``g e`` in ``g`` is the identity). The left-invariant field is
    ``d/ds g exp(s e_b)``; compare."""
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in gm.X0]
        true = gm.jacobian(
            lambda s: gm.coords(gm.group_element(x) * gm.group_element(s)), [mpmath.mpf(0)] * 3
        )  # d/ds x(g exp(s e_b))
        printed = gm.jacobian(
            lambda y: gm.coords(gm.group_element(y) * gm.group_element([0, 0, 0])), x
        )  # d(g h)/dg at h = e
        err = gm.maxabs(printed - true)
    return within(err, "d(gh)/dg at h=e vs d/ds g exp(s e_b)")


def twee1_frame_corrected() -> Outcome:
    """Corrected: ``L^a_b(g, h) = d(gh)^a / dh^b``; then ``L(g, e) = phi1(-ad_x)^-1`` (docs/conventions.md)
    and ``L(g^-1, g) = phi1(-ad_x)`` (twee1, twee4, twee5: the coframe is dual to the frame)."""
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in gm.X0]
        dh = gm.jacobian(
            lambda y: gm.coords(gm.group_element(x) * gm.group_element(y)), [mpmath.mpf(0)] * 3
        )  # d(gh)/dh at h = e
        xm = [-v for v in x]
        dh_co = gm.jacobian(
            lambda y: gm.coords(gm.group_element(xm) * gm.group_element(y)), x
        )  # d(g^-1 h)/dh at h = g
        A = gm.phi1(-gm.ad(x))
        err = max(
            gm.maxabs(dh - mpmath.inverse(A)),
            gm.maxabs(dh_co - A),
            gm.maxabs(dh_co * dh - mpmath.eye(3)),
        )
    return within(err, "L(g,e) = phi1(-ad_x)^-1, L(g^-1,g) = phi1(-ad_x)")


def twee3_coadjoint() -> Outcome:
    """``pi^R = Ad(g^-1)^T pi^L`` with ``pi^L_m = p_n L^n_m(g, e)``, ``pi^R_m = p_n R^n_m(g, e)``,
    ``R(g, e) = d(hg)/dh`` at ``h = e`` (right-invariant frame)."""
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in gm.X0]
        p = mpmath.matrix(["0.3", "-1.1", "0.8"])
        L = gm.jacobian(
            lambda y: gm.coords(gm.group_element(x) * gm.group_element(y)), [mpmath.mpf(0)] * 3
        )
        R = gm.jacobian(
            lambda y: gm.coords(gm.group_element(y) * gm.group_element(x)), [mpmath.mpf(0)] * 3
        )
        piL, piR = L.T * p, R.T * p
        Ad_inv = mpmath.expm(-gm.ad(x))
        err = gm.maxabs(piR - Ad_inv.T * piL)
    return within(err, "pi^R vs Ad(g^-1)^T pi^L")


_LVEC, _GAMMA = ("0.2", "-0.5", "1.1"), ("0.6", "0.3", "-0.9")


def twee16_gravity_gradient() -> Outcome:
    """``<dV|e^L_mu> = -(Gamma | ad(e_mu) L)``, ``Gamma = Ad(g)^T gamma``, for ``V = -(gamma | Ad(g) L)``."""
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in gm.X0]
        L, gam = mpmath.matrix(list(_LVEC)), mpmath.matrix(list(_GAMMA))
        Ad = mpmath.expm(gm.ad(x))

        def V(s, mu):
            e = [mpmath.mpf(0)] * 3
            e[mu] = s
            return -(gam.T * (Ad * mpmath.expm(gm.ad(e))) * L)[0]

        lhs = [mpmath.diff(lambda s, mu=mu: V(s, mu), 0) for mu in range(3)]
        Gam = Ad.T * gam
        rhs = [
            -sum(Gam[a] * gm.levi_civita(a, mu, b) * L[b] for a in range(3) for b in range(3))
            for mu in range(3)
        ]
        err = max(abs(u - v) for u, v in zip(lhs, rhs))
    return within(err, "derivative of V along g exp(s e_mu)")


def _gamma_rate(Omega):
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in gm.X0]
        gam = mpmath.matrix(list(_GAMMA))
        Ad = mpmath.expm(gm.ad(x))
        dG = [
            mpmath.diff(
                lambda s, m=m: ((Ad * mpmath.expm(gm.ad([s * o for o in Omega]))).T * gam)[m], 0
            )
            for m in range(3)
        ]
        return dG, Ad.T * gam


_OMEGA = ("0.7", "0.2", "-0.4")


def _twee17(index, label: str) -> Outcome:
    """``dGamma_mu/dt`` along ``dg/dt = g Omega`` against ``sum_ab Gamma_a Omega^b eps(index(a, b, mu))``."""
    with mpmath.workdps(DPS + 15):
        Om = [mpmath.mpf(v) for v in _OMEGA]
        dG, G = _gamma_rate(Om)
        form = [
            sum(G[a] * Om[b] * gm.levi_civita(*index(a, b, mu)) for a in range(3) for b in range(3))
            for mu in range(3)
        ]
        err = max(abs(u - v) for u, v in zip(dG, form))
        tol = tolerance(max(abs(v) for v in dG))
    return Outcome(bool(err <= tol), float(err), float(tol), label)


def twee17_printed() -> Outcome:
    """Printed: ``dGamma_mu/dt = Gamma_a f^a_{mu b} Omega^b`` along ``dg/dt = g Omega``."""
    return _twee17(lambda a, b, mu: (a, mu, b), "printed sign")


def twee17_corrected() -> Outcome:
    """Corrected: ``dGamma_mu/dt = Omega^b f^a_{b mu} Gamma_a = (ad_Omega^T Gamma)_mu``
    (for so(3): ``dGamma/dt = Gamma x Omega``)."""
    return _twee17(lambda a, b, mu: (a, b, mu), "corrected sign")


def _ref_field(theta, ups, pot, x, pi, inertia=((2, 0, 0), (0, 3, 0), (0, 0, 5))):
    ref = Reference(DPS)
    return ref.hamiltonian_vector_field_mp(
        su2(), theta, ups, [list(r) for r in inertia], pot, x, pi
    )


def euler_equations_printed() -> Outcome:
    """twee12/twee14/twee18 (Theta = 0) and drie5/drie6/drie12 (Theta = -xi.f), as printed, against
    the reference vector field (vier10, vier11 with Upsilon = 0, Phi = Psi = 1) for su(2) with gravity:
    ``dpi_mu/dt = -dV_mu + Omega^a (pi_k f^k_{a mu} - Theta_{a mu})`` with
    ``-dV_mu = Gamma_a f^a_{mu b} L^b`` (twee18), and for drie12 ``dpi'/dt`` with ``pi' = pi + xi``."""
    xi = ["1/3", "-1/5", "2/7"]
    theta = [
        [
            sp.Rational(0) - sum(sp.Rational(xi[k]) * gm.levi_civita(k, a, b) for k in range(3))
            for b in range(3)
        ]
        for a in range(3)
    ]
    zero = [[0] * 3 for _ in range(3)]
    pot = {"kind": "gravity", "L": list(_LVEC), "gamma": list(_GAMMA)}
    pi = ["0.5", "-0.3", "0.8"]
    worst, tol_w = mpmath.mpf(0), mpmath.mpf(0)
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in gm.X0]
        Gam = mpmath.expm(gm.ad(x)).T * mpmath.matrix(list(_GAMMA))
        L = mpmath.matrix(list(_LVEC))
        Iinv = [mpmath.mpf(1) / 2, mpmath.mpf(1) / 3, mpmath.mpf(1) / 5]
        piv = [mpmath.mpf(v) for v in pi]
        Om = [Iinv[a] * piv[a] for a in range(3)]
        for th, xs in (
            (zero, [0, 0, 0]),
            (theta, [mpmath.mpf(sp.Rational(v).p) / sp.Rational(v).q for v in xi]),
        ):
            xd, pd = _ref_field(th, zero, pot, list(gm.X0), pi)
            thm = [
                [mpmath.mpf(sp.Rational(th[a][b]).p) / sp.Rational(th[a][b]).q for b in range(3)]
                for a in range(3)
            ]
            # twee18 / drie6 form
            pr = [
                -sum(piv[a] * gm.levi_civita(a, mu, b) * Om[b] for a in range(3) for b in range(3))
                + sum(Gam[a] * gm.levi_civita(a, mu, b) * L[b] for a in range(3) for b in range(3))
                - sum(Om[a] * thm[a][mu] for a in range(3))
                for mu in range(3)
            ]
            # drie12 form in pi' (same time derivative since xi is constant)
            pp = [piv[k] + xs[k] for k in range(3)]
            pr12 = [
                sum(Gam[a] * gm.levi_civita(a, mu, b) * L[b] for a in range(3) for b in range(3))
                + sum(Om[a] * pp[k] * gm.levi_civita(k, a, mu) for a in range(3) for k in range(3))
                for mu in range(3)
            ]
            # drie4 / twee13: Omega = L(g^-1, g) xdot = phi1(-ad_x) xdot
            Om_ref = gm.phi1(-gm.ad(x)) * xd
            scale = max(abs(v) for v in pd)
            err = max(
                [abs(pd[m] - pr[m]) for m in range(3)]
                + [abs(pd[m] - pr12[m]) for m in range(3)]
                + [abs(Om_ref[m] - Om[m]) for m in range(3)]
            )
            worst = max(worst, err)
            tol_w = max(tol_w, tolerance(scale))
    return Outcome(
        bool(worst <= tol_w),
        float(worst),
        float(tol_w),
        "twee13/14/18, drie4/5/6/11/12 vs reference",
    )


def euler_equations_general(
    names=("sl(2,R)", "Bianchi III", "h(3)", "se(3)"), seed: int = 1
) -> Outcome:
    """twee12/twee14/twee18 and drie5/drie6 for other algebras (f from the catalogue, a random rational
    cocycle Theta, Upsilon = 0, gravity): the printed right-hand side
    ``dpi_m/dt = -pi_a f^a_mb Omega^b + Gamma_a f^a_mb L^b - Omega^a Theta_am`` (twee18 with drie6)
    and ``Omega = phi1(-ad_x) xdot = I^-1 pi`` (twee13, drie4) against the reference vector field."""
    worst, tol_w, det = mpmath.mpf(0), mpmath.mpf(0), []
    for name in names:
        alg, F, Th, _U = algebras.random_model(name, seed)
        n = alg.dim
        rnd = random.Random(seed + 2)
        xs = [sp.Rational(rnd.randint(-9, 9), 10) for _ in range(n)]
        ps = [sp.Rational(rnd.randint(-9, 9), 10) for _ in range(n)]
        Ls = [sp.Rational(rnd.randint(-9, 9), 10) for _ in range(n)]
        gs = [sp.Rational(rnd.randint(-9, 9), 10) for _ in range(n)]
        Id = [k + 1 for k in range(n)]
        inertia = [[Id[i] if i == j else 0 for j in range(n)] for i in range(n)]
        zero = [[0] * n for _ in range(n)]
        pot = {"kind": "gravity", "L": [str(v) for v in Ls], "gamma": [str(v) for v in gs]}
        xd, pd = Reference(DPS).hamiltonian_vector_field_mp(
            alg, Th.tolist(), zero, inertia, pot, [str(v) for v in xs], [str(v) for v in ps]
        )
        with mpmath.workdps(DPS + 15):

            def mp(v):
                return mpmath.mpf(sp.Rational(v).p) / sp.Rational(v).q

            Fm = [[[mp(F[m, a, b]) for b in range(n)] for a in range(n)] for m in range(n)]
            x = [mp(v) for v in xs]
            pi = [mp(v) for v in ps]
            L = [mp(v) for v in Ls]
            ad = mpmath.matrix(
                [[sum(x[a] * Fm[m][a][b] for a in range(n)) for b in range(n)] for m in range(n)]
            )
            Gam = mpmath.expm(ad).T * mpmath.matrix([mp(v) for v in gs])
            Om = [pi[a] / Id[a] for a in range(n)]
            thm = [[mp(Th[a, b]) for b in range(n)] for a in range(n)]
            pr = [
                -sum(pi[a] * Fm[a][mu][b] * Om[b] for a in range(n) for b in range(n))
                + sum(Gam[a] * Fm[a][mu][b] * L[b] for a in range(n) for b in range(n))
                - sum(Om[a] * thm[a][mu] for a in range(n))
                for mu in range(n)
            ]
            Om_ref = gm.phi1(-ad) * xd
            scale = max([mpmath.mpf(1)] + [abs(v) for v in pd])
            err = max(
                [abs(pd[m] - pr[m]) for m in range(n)] + [abs(Om_ref[m] - Om[m]) for m in range(n)]
            )
            worst = max(worst, err / scale)
            tol_w = tolerance()
            det.append(f"{name}: {float(err):.1e}")
    return Outcome(bool(worst <= tol_w), float(worst), float(tol_w), "; ".join(det))


def _right_frame(printed: bool) -> Outcome:
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in gm.X0]
        zero = [mpmath.mpf(0)] * 3
        true = gm.jacobian(
            lambda s: gm.coords(gm.group_element(s) * gm.group_element(x)), zero
        )  # d/ds x(exp(s e_b) g): right-invariant field
        if printed:
            R_ = gm.jacobian(
                lambda y: gm.coords(gm.group_element(zero) * gm.group_element(y)), x
            )  # R(g, e) = d(h g)/dg at h = e
        else:
            R_ = gm.jacobian(
                lambda y: gm.coords(gm.group_element(y) * gm.group_element(x)), zero
            )  # R(g, e) = d(h g)/dh at h = e
        Rco = gm.jacobian(
            lambda y: gm.coords(gm.group_element(y) * gm.group_element([-v for v in x])), x
        )  # R(g^-1, g) = d(h g^-1)/dh at h = g
        A = gm.phi1(gm.ad(x))  # right coframe: eps_R = phi1(ad_x) dx, the frame its inverse
        err = max(gm.maxabs(R_ - true), 0 if printed else gm.maxabs(Rco * R_ - mpmath.eye(3)))
        if not printed:
            err = max(err, gm.maxabs(Rco - A))
    tol = tolerance()
    return Outcome(bool(err <= tol), float(err), float(tol), "R(g,e) vs d/ds x(exp(s e_b) g)")


def deux_right_frame_printed() -> Outcome:
    """Printed (inline, before twee1): ``R^a_b(g, h) = d(hg)^a/dg^b``, so ``e^R_b = R^m_b(g, e) d/dg^m``
    would be ``d/dg^b``; the right-invariant field is ``d/ds x(exp(s e_b) g)``. Expected to FAIL
    (the twee1 erratum, right-handed half)."""
    return _right_frame(True)


def deux_right_frame_corrected() -> Outcome:
    """Corrected: ``R^a_b(g, h) = d(hg)^a/dh^b``; then ``R(g, e)`` is the right-invariant frame,
    ``R(g^-1, g) = phi1(ad_x)`` its dual coframe (45 digits)."""
    return _right_frame(False)


def deux_maurer_cartan() -> Outcome:
    """Unlabelled display ``D(g^-1) dD(g) = D'(g^-1 dg)`` and the inline ``dAd(g) = Ad(g) ad(e_m) eps_L^m``,
    ``dK(g) = K(g) k(e_m) eps_L^m`` with ``k(u) = -ad(u)^T``, ``K(g) = Ad(g^-1)^T``: for D the spin-1/2
    matrices, Ad and K, ``D(g)^-1 d D/dx^b = sum_a D'(e_a) phi1(-ad_x)^a_b`` (the left coframe) at
    45 digits on su(2) (derivatives by mpmath.diff)."""
    worst = mpmath.mpf(0)
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in gm.X0]
        E = gm.basis()
        A = gm.phi1(-gm.ad(x))
        reps = {
            "spin-1/2": (lambda y: gm.group_element(y), lambda a: E[a]),
            "Ad": (
                lambda y: mpmath.expm(gm.ad(y)),
                lambda a: gm.ad([1 if i == a else 0 for i in range(3)]),
            ),
            "K": (
                lambda y: mpmath.expm(-gm.ad(y)).T,
                lambda a: -gm.ad([1 if i == a else 0 for i in range(3)]).T,
            ),
        }
        for D, Dp in reps.values():
            D0inv = mpmath.inverse(D(x))
            for b in range(3):
                dD = D0inv * _mdiff(D, x, b)
                rhs = sum((Dp(a) * A[a, b] for a in range(3)), mpmath.zeros(D(x).rows, D(x).cols))
                worst = max(worst, gm.maxabs(dD - rhs))
    tol = tolerance()
    return Outcome(bool(worst <= tol), float(worst), float(tol), "spin-1/2, Ad, K on su(2)")


def _mdiff(D, x, b):
    """``d D(x) / dx^b`` entrywise by mpmath.diff."""
    M0 = D(x)
    out = mpmath.zeros(M0.rows, M0.cols)
    for i in range(M0.rows):
        for j in range(M0.cols):
            out[i, j] = mpmath.diff(
                lambda s, i=i, j=j: D([x[k] + (s if k == b else 0) for k in range(3)])[i, j], 0
            )
    return out


def deux_lifted_action() -> Outcome:
    """Sentences of deux: the lift of left multiplication, ``p'_{ag} = L^*_{a^-1|ag} p_g``, keeps the body
    momenta: ``pi^L(ag, p') = pi^L(g, p)``, ``pi^L_m = p_n L^n_m(g, e)``, ``L(g, e) = d(gh)/dh`` at
    ``h = e`` (corrected twee1); and the left coframe ``L(g^-1, g) dg`` is invariant under ``g -> ag``
    (45 digits)."""
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in gm.X0]
        a = [mpmath.mpf(v) for v in ("-0.3", "0.5", "0.2")]
        zero = [mpmath.mpf(0)] * 3
        p = mpmath.matrix(["0.3", "-1.1", "0.8"])
        ag = gm.coords(gm.group_element(a) * gm.group_element(x))
        ainv = [-v for v in a]
        # (L_{a^-1})^* at ag: p'_nu = p_mu d(a^-1 h)^mu / dh^nu at h = ag
        Jl = gm.jacobian(lambda h: gm.coords(gm.group_element(ainv) * gm.group_element(h)), ag)
        pprime = Jl.T * p
        L_g = gm.jacobian(lambda h: gm.coords(gm.group_element(x) * gm.group_element(h)), zero)
        L_ag = gm.jacobian(lambda h: gm.coords(gm.group_element(ag) * gm.group_element(h)), zero)
        err = gm.maxabs(L_ag.T * pprime - L_g.T * p)
        # the left coframe L(g^-1, g) dg is invariant: eps_L(ag) . d(a h)/dh|_{h=g} = eps_L(g)
        co = lambda y: gm.jacobian(
            lambda h: gm.coords(gm.group_element([-v for v in y]) * gm.group_element(h)), y
        )
        push = gm.jacobian(lambda h: gm.coords(gm.group_element(a) * gm.group_element(h)), x)
        err = max(err, gm.maxabs(co(ag) * push - co(x)))
    tol = tolerance()
    return Outcome(bool(err <= tol), float(err), float(tol), "pi^L(ag, p') vs pi^L(g, p)")


CHECKS = {
    "twee1_frame_printed": twee1_frame_printed,
    "twee1_frame_corrected": twee1_frame_corrected,
    "twee3_coadjoint": twee3_coadjoint,
    "twee16_gravity_gradient": twee16_gravity_gradient,
    "twee17_printed": twee17_printed,
    "twee17_corrected": twee17_corrected,
    "euler_equations": euler_equations_printed,
    "euler_equations_general": euler_equations_general,
    "deux_right_frame_printed": deux_right_frame_printed,
    "deux_right_frame_corrected": deux_right_frame_corrected,
    "deux_maurer_cartan": deux_maurer_cartan,
    "deux_lifted_action": deux_lifted_action,
}
