"""The float64 judges of the certification and their error models (docs/conventions.md, "Errors and
tolerances").

* :func:`conditioning`, :func:`cond_omega`, :func:`tolerance`, :func:`flow_tol`: the error model of
  every certification check, ``tol = C n eps_impl kappa frame scale`` (below);
* :class:`FloatJudge`: an independent float64 flow judge (scipy's DOP853 on the body system);
* :func:`compare_state`: a flow's end state against the judge's, through ``x`` where unique,
  ``Ad(g)`` chart-free, and ``rho(g)`` in a faithful representation;
* :func:`reference_work`, :func:`meets_degenerate_set`: what a flow example costs, and whether its
  trajectory ends on the degenerate set.

Error model: ``tol = C * n * eps_impl * kappa * frame * scale`` at the point, with ``C = 8``,
``kappa = max(cond_phi, cond_data) + route`` (``cond_phi = ||Phi||_F ||Phi^-1||_F / n``,
``cond_data = ||Phi^-1||_F (1 + ||S||_F ||U||_F) / sqrt(n)``; ``route = e^min(||ad_x||_1, 5.37) + s``
the error factor of the standard routes to the frame ``phi1(-ad_x)``: series, expm with scaling and
squaring, Van Loan's block; :func:`expm_route`), ``frame = 1/(1 - r)``,
``r >= ||ad_x||_2 / 2 pi``, ``scale = max(1, max|ref|)`` and
``eps_impl = 10^-precision_digits`` (float64's eps when absent). Antisymmetry uses in addition
the condition of the holonomic omega_L matrix ``W_h`` (``P = -W_h^-1``): an inverse computed
without symmetrisation is asymmetric by up to ``~ n eps cond(W_h) max|P|``. Flows use
``max(flow_tolerance, that)`` with the declared ``flow_tolerance`` (default 1e-9).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from scipy.integrate import solve_ivp

from tstarg.refimpl import PROTOCOL, RepresentationError, representation_for

__all__ = [
    "C_CERT",
    "DEGENERATE_APPROACH",
    "EPS64",
    "THETA13",
    "JUDGE_RTOL",
    "FloatJudge",
    "MatrixGroup",
    "ad",
    "centre_representation",
    "compare_state",
    "cond_omega",
    "conditioning",
    "eps_impl",
    "expm_route",
    "flow_tol",
    "frame_route",
    "max_err",
    "meets_degenerate_set",
    "phi1",
    "reference_work",
    "sensitivity_at",
    "tolerance",
]

C_CERT = 8.0

EPS64 = float(np.finfo(float).eps)

JUDGE_RTOL = 1e-13


def eps_impl(impl) -> float:
    digits = getattr(impl, "precision_digits", None)
    return EPS64 if digits is None else max(EPS64, 10.0 ** (-float(digits)))


def ad(f, x):
    return np.einsum("a,mab->mb", x, f)


# Independent of refimpl/_phi.py on purpose: the judge must not share the code it judges.
def expm(A: np.ndarray) -> np.ndarray:
    """``exp(A)``: scipy's Pade on ``A / 2^k`` with ``||A / 2^k||_1 <= 1``, raised to ``2^k`` by
    ``matrix_power``. scipy 1.17.1's own choice of scaling errs by thousands of ulp on benign matrices
    (2332 ulp on ``[[4, 0.1], [0.1, 0]]``, against mpmath), beyond :func:`expm_route`'s model; at
    1-norm <= 1 its Pade is within an ulp, and the squarings are inside the model."""
    r = float(np.abs(A).sum(axis=-2).max(initial=0.0))
    k = max(0, math.ceil(math.log2(r))) if r > 1.0 else 0
    return np.linalg.matrix_power(scipy.linalg.expm(A * 0.5**k), 2**k)


def phi1(M: np.ndarray) -> np.ndarray:
    """``phi1(M) = sum M^k/(k+1)!`` from the exponential of a block matrix."""
    n = M.shape[0]
    big = np.zeros((2 * n, 2 * n))
    big[:n, :n] = M
    big[:n, n:] = np.eye(n)
    return expm(big)[:n, n:]


THETA13 = 5.37
"""Higham (2005), scaling and squaring: ``expm`` evaluates the degree-13 Pade approximant on
``A / 2^s`` with ``||A / 2^s||_1 <= theta_13 = 5.37`` (scipy.linalg.expm, MATLAB, Julia)."""


def expm_route(norm1: float) -> float:
    """Error factor (relative, over ``c n eps``) of every standard float64 route to ``exp(A)`` and to
    ``phi1(A) = sum A^k / (k+1)!`` (the frame ``phi1(-ad_x)``) for ``||A||_1 = norm1``: the larger of

    * the Taylor series (the route of a first-principles implementation): its terms have norms
      ``||A||^k / (k+1)!``, summing to ``(e^r - 1) / r <= e^r`` (``r = ||A||``); each partial sum
      rounds by ``gamma_{kn}`` of that sum, so the error is ``<= c n eps e^r`` while ``phi1`` itself
      may be of size 1 (cancellation, e.g. skew ``A``);
    * ``expm`` (of ``A``, or of Van Loan's block ``[[A, 1], [0, 0]]`` whose top-right block is
      ``phi1(A)``; the block's 1-norm is ``max(||A||_1, 1)``) with scaling and squaring: the Pade
      numerator ``p(B)`` (``B = A / 2^s``) is a sum of terms of total norm ``p(||B||) <= e^{||B||/2}``
      and is divided by ``q(B) ~ e^{-B/2}`` with ``||q(B)^-1|| <= e^{||B||/2}``, so the evaluation
      errs by ``<= c n eps e^{||B||}``, ``||B|| <= min(||A||, theta_13)``; each of the ``s``
      squarings adds ``gamma_n`` relative (for the near-normal ``ad_x`` of compact algebras; for
      others the squarings amplify by ``||e^{B}||^{2^s} / ||e^A||``, bounded here by the ``e^{||B||}``
      already counted once ``s`` is 0 or 1, which the draws inside the chart keep).

    Measured (issue 26): the Van Loan block route errs by 130 ulp in ``P`` at ``x = (0, 0, 4)`` on
    su(2), ``||ad_x||_1 = 4``: within ``8 n eps e^4``."""
    r = max(1.0, float(norm1))
    s = max(0, math.ceil(math.log2(r / THETA13))) if r > THETA13 else 0
    return math.exp(min(r, THETA13)) + s


def frame_route(f, x) -> float:
    """:func:`expm_route` of the frame ``phi1(-ad_x)`` at ``x``."""
    return expm_route(float(np.abs(ad(f, np.asarray(x, dtype=float))).sum(0).max()))


def conditioning(f, theta, ups, x, pi) -> tuple[float, float]:
    """``kappa`` and ``frame`` at a point, from float64 arithmetic on the inputs; every check's
    tolerance is ``C n eps kappa frame scale``.

    ``kappa = max(cond_phi, cond_data) + route``: the two sources of error add. Inverting ``Phi``
    errs by ``eps`` times its conditioning; computing the frame ``phi1(-ad_x)`` errs by ``eps`` times
    :func:`frame_route` (series, or expm with scaling and squaring), relative, and ``L = J^-1`` carries
    that relative error into ``P`` unamplified by ``Phi`` (``P_{x pi} = L Psi^-1``: ``dP = dL Psi^-1``).
    ``frame = 1 / (1 - r)`` (``r >= ||ad_x||_2 / 2 pi``) is the conditioning of ``L(g, e)`` near the
    chart edge, which multiplies both. Every check's tolerance thus admits every standard route to
    the frame without loosening the degenerate regime (where ``cond_phi`` dominates)."""
    n = f.shape[0]
    S = np.einsum("m,mab->ab", pi, f) - theta
    Phi = np.eye(n) + S @ ups
    try:
        Pinv = np.linalg.inv(Phi)
    except np.linalg.LinAlgError:
        return math.inf, 1.0
    fro = np.linalg.norm
    cond = max(fro(Phi) * fro(Pinv) / n, fro(Pinv) * (1 + fro(S) * fro(ups)) / math.sqrt(n))
    A = ad(f, x)
    r = (
        min(fro(A), math.sqrt(np.abs(A).sum(0).max() * np.abs(A).sum(1).max())) / (2 * math.pi)
        if A.any()
        else 0.0
    )
    return cond + frame_route(f, x), 1.0 / max(1e-300, 1.0 - min(r, 0.999999))


def cond_omega(f, theta, ups, x, pi) -> float:
    """2-norm condition of the holonomic omega_L matrix ``W_h = [[A^T S A, A^T], [-A, U]]``
    (``A = phi1(-ad_x)``, ``eps_L = A dx``), whose inverse is ``-P``: a plain float64 inversion
    errs by ``~ eps cond(W_h) |P|`` in every entry, symmetric part included."""
    A = phi1(-ad(f, x))
    S = np.einsum("m,mab->ab", pi, f) - theta
    W = np.block([[A.T @ S @ A, A.T], [-A, ups]])
    try:
        return float(np.linalg.cond(W))
    except np.linalg.LinAlgError:
        return math.inf


def tolerance(impl, n, cond, frame, ref) -> float:
    scale = max(1.0, float(np.max(np.abs(ref))))
    return C_CERT * n * eps_impl(impl) * cond * frame * scale


def max_err(got, ref) -> float:
    return float(np.max(np.abs(got - ref))) if np.all(np.isfinite(got)) else math.inf


def flow_tol(impl, n, cond, frame) -> float:
    return max(
        float(PROTOCOL.declared(impl, "flow_tolerance")), C_CERT * n * eps_impl(impl) * cond * frame
    )


class FloatJudge:
    """An independent float64 flow judge: scipy's DOP853 on the body system of vier10/vier11 with
    ``Ad(g)`` carried along (``d Ad(g)/dt = Ad(g) ad_Omega`` for ``g^-1 dg/dt = Omega``), chart-free;
    ``x`` is integrated too (``xdot = phi1(-ad_x)^-1 Omega``) until ``||ad_x||_2`` reaches
    ``0.9 * 2 pi``, after which only ``(pi, Ad)`` are carried. Gravity: ``Gamma = Ad(g)^T gamma``,
    ``dV_b = -Gamma_m f^m_bc L^c`` (twee15/twee16).

    ``rep`` (a :class:`MatrixGroup`: the group the flow is judged on) also carries ``G = rho(g)``,
    ``dG/dt = G rho(Omega)``: faithful on the group, it sees what ``Ad`` cannot (the central part of
    ``g``; the sheet of SU(2) over SO(3)). ``group=True`` without ``rep``: refimpl's faithful
    representation where the centre is non-trivial (:func:`centre_representation`)."""

    def __init__(self, f, theta, ups, inertia, potential, group=False, rep=None):
        self.f, self.theta, self.U = (np.array(a, dtype=float) for a in (f, theta, ups))
        self.n = self.f.shape[0]
        self.rep = rep if rep is not None else (centre_representation(self.f) if group else None)
        self.r = 0 if self.rep is None else self.rep.dim
        self.Iinv = np.linalg.inv(np.array(inertia, dtype=float))
        self.pot = (
            None
            if potential is None
            else (np.array(potential["L"], float), np.array(potential["gamma"], float))
        )

    def body(self, pi, Ad):
        n = self.n
        S = np.einsum("m,mab->ab", pi, self.f) - self.theta
        dK = self.Iinv @ pi
        dV = np.zeros(n)
        if self.pot is not None:
            L, gamma = self.pot
            dV = -np.einsum("m,mbc,c->b", Ad.T @ gamma, self.f, L)
        Omega = np.linalg.solve(np.eye(n) + self.U @ S, dK - self.U @ dV)
        pidot = np.linalg.solve(np.eye(n) + S @ self.U, -dV - S @ dK)
        return Omega, pidot

    def rhs(self, t, y, with_x):
        n, r = self.n, self.r
        pi, Ad = y[:n], y[n : n + n * n].reshape(n, n)
        Omega, pidot = self.body(pi, Ad)
        out = [pidot, (Ad @ ad(self.f, Omega)).ravel()]
        if r:
            G = y[n + n * n : n + n * n + r * r].reshape(r, r)
            out.append((G @ self.rep.matrix(Omega)).ravel())
        if with_x:
            x = y[n + n * n + r * r :]
            out.append(np.linalg.solve(phi1(-ad(self.f, x)), Omega))
        return np.concatenate(out)

    def energy(self, pi, Ad):
        H = 0.5 * pi @ self.Iinv @ pi
        if self.pot is not None:
            H -= (Ad.T @ self.pot[1]) @ self.pot[0]
        return H

    def run(self, x0, pi0, t, rtol=JUDGE_RTOL):
        """``(x or None, pi, Ad)`` at ``t`` (``x`` None once it approached the chart edge); with a
        representation, ``G = rho(g(t))`` in :attr:`last_group` (None without one)."""
        (out,), groups = self.run_at(x0, pi0, [t], rtol)
        self.last_group = groups[0]
        return out

    def run_at(self, x0, pi0, times, rtol=JUDGE_RTOL):
        """The states ``(x or None, pi, Ad)`` at every time of ``times`` (one sign, any order) from one
        integration (DOP853's dense output between steps), and ``rho(g(t))`` at each (None without a
        representation)."""
        n, r = self.n, self.r
        k = n + n * n + r * r  # where x starts in the state
        times = [float(t) for t in times]
        if any(t > 0 for t in times) and any(t < 0 for t in times):
            raise ValueError("run_at: times must have one sign")
        x0 = np.asarray(x0, dtype=float)
        Ad0 = expm(ad(self.f, x0))
        G0 = [] if r == 0 else [self.rep.exp(x0).ravel()]
        y0 = np.concatenate([np.asarray(pi0, dtype=float), Ad0.ravel(), *G0, x0])
        scale = max(1.0, float(np.max(np.abs(y0))))
        end = max(times, key=abs)
        found: dict[float, tuple] = {}
        if end == 0:
            return [(x0.copy(), np.array(pi0, float), Ad0) for _ in times], [
                G0[0].reshape(r, r) if r else None for _ in times
            ]

        def edge(s, y, w):
            return np.linalg.norm(ad(self.f, y[k:]), 2) - 0.9 * 2 * np.pi

        edge.terminal = True
        want = sorted({t for t in times if t != 0}, key=abs)
        sol = solve_ivp(
            self.rhs,
            (0.0, end),
            y0,
            method="DOP853",
            rtol=rtol,
            atol=rtol * scale,
            args=(True,),
            events=edge,
            dense_output=True,
        )
        if sol.status < 0:
            raise ArithmeticError(f"judge failed: {sol.message}")
        t_edge = sol.t[-1]
        for t in want:
            if abs(t) <= abs(t_edge):
                y = sol.y[:, -1] if t == t_edge else sol.sol(t)
                found[t] = (y[k:], y[:k])
        rest = [t for t in want if t not in found]
        if rest:  # x reached the chart edge: carry (pi, Ad, G) on
            sol2 = solve_ivp(
                self.rhs,
                (t_edge, end),
                sol.y[:k, -1],
                method="DOP853",
                rtol=rtol,
                atol=rtol * scale,
                args=(False,),
                dense_output=True,
            )
            if sol2.status < 0:
                raise ArithmeticError(f"judge failed: {sol2.message}")
            for t in rest:
                y = sol2.y[:, -1] if t == end else sol2.sol(t)
                found[t] = (None, y[:k])
        out, groups = [], []
        for t in times:
            if t == 0:
                out.append((x0.copy(), np.array(pi0, float), Ad0))
                groups.append(G0[0].reshape(r, r) if r else None)
                continue
            x, y = found[t]
            out.append(
                (None if x is None else np.array(x), y[:n].copy(), y[n : n + n * n].reshape(n, n))
            )
            groups.append(y[n + n * n : k].reshape(r, r) if r else None)
        return out, groups

    def judged(self, x0, pi0, t):
        """The judge at rtol 1e-13 and its error (the difference from a run at rtol 1e-12)."""
        (a,), (ga,), errs = self.judged_at(x0, pi0, [t])
        return (a, errs[0]) if ga is None else (a, errs[0], ga)

    def judged_at(self, x0, pi0, times):
        """:meth:`run_at` at rtol 1e-13, and per time its error estimate: the difference from a run
        at rtol 1e-12, per part ``(x or None, pi, Ad[, G])``. An estimate (DOP853's error at rtol
        1e-13 is about a tenth of its error at 1e-12 for a smooth problem), not a bound."""
        a, ga = self.run_at(x0, pi0, times)
        b, gb = self.run_at(x0, pi0, times, rtol=10 * JUDGE_RTOL)
        errs = []
        for (ax, ap, aA), (bx, bp, bA), g1, g2 in zip(a, b, ga, gb):
            ex = None if ax is None or bx is None else float(np.max(np.abs(ax - bx)))
            e = (ex, float(np.max(np.abs(ap - bp))), float(np.max(np.abs(aA - bA))))
            errs.append(e if g1 is None else e + (float(np.max(np.abs(g1 - g2))),))
        return a, ga, errs


def sensitivity_at(judge, x0, pi0, times, states, groups) -> list[float]:
    """An estimate of the condition of the flow map at each time: ``sqrt(2n) |Phi(z0 + h u) -
    Phi(z0)|_inf / h`` for a fixed unit direction ``u`` (``h = 1e-6 max(1, |z0|)``), over ``pi``,
    ``Ad(g)`` and ``rho(g)``, at least 1. A backward-stable integrator (the exact flow of a start
    perturbed by its tolerance ``tau``) errs by ``tau ||D Phi||``; for a random direction
    ``E |D Phi u|^2 = ||D Phi||_F^2 / 2n``, so the factor ``sqrt(2n)`` recovers the Frobenius norm,
    an upper bound of ``||D Phi||_2``, on average (an estimate, not a bound). The perturbed run is
    at rtol 1e-11: its error over ``h`` is ~1e-5 of the estimate."""
    n = judge.n
    u = np.cos(np.arange(1, 2 * n + 1) * 1.618)  # a fixed direction, every component nonzero
    u /= np.linalg.norm(u)
    x0, pi0 = np.asarray(x0, dtype=float), np.asarray(pi0, dtype=float)
    h = 1e-6 * max(1.0, float(np.max(np.abs(np.concatenate([x0, pi0])))))
    moved, mgroups = judge.run_at(x0 + h * u[:n], pi0 + h * u[n:], times, rtol=1e-11)
    out = []
    for (_, ap, aA), (_, bp, bA), g1, g2 in zip(states, moved, groups, mgroups):
        d = max(float(np.max(np.abs(ap - bp))), float(np.max(np.abs(aA - bA))))
        if g1 is not None:
            d = max(d, float(np.max(np.abs(g1 - g2))))
        out.append(max(1.0, math.sqrt(2 * n) * d / h))
    return out


class MatrixGroup:
    """The group generated by a faithful representation ``rho(e_a) = mats[a]`` (``(n, r, r)``) of an
    algebra, named ``name``: ``exp``, ``matrix`` and ``dim`` as :class:`refimpl._representation.
    Representation`. Complex matrices (su(2)'s ``E_a = -(i/2) sigma_a``) are carried realified,
    ``[[Re, -Im], [Im, Re]]``: the same group, real for the ODE judges."""

    def __init__(self, mats, name: str):
        mats = np.asarray(mats)
        if np.iscomplexobj(mats):
            re, im = mats.real.astype(float), mats.imag.astype(float)
            if np.any(im):
                mats = np.concatenate(
                    [np.concatenate([re, -im], axis=2), np.concatenate([im, re], axis=2)], axis=1
                )
            else:
                mats = re
        self.mats = np.asarray(mats, dtype=float)
        self.name = name

    @property
    def dim(self) -> int:
        return int(self.mats.shape[-1])

    def matrix(self, x):
        return np.einsum("...a,aij->...ij", np.asarray(x, dtype=float), self.mats)

    def exp(self, x):
        return expm(self.matrix(x))


def centre_representation(f):
    """A faithful representation of ``f`` (refimpl's, :func:`refimpl._representation.representation_for`)
    when the centre is non-trivial, where ``Ad(g) = expm(ad_x)`` is blind to the central part of
    ``g``; None for a trivial centre (``Ad`` is then faithful on the image of exp up to the finite
    kernel the flows' ``x`` comparison sees) or when no representation can be built."""

    f = np.asarray(f, dtype=float)
    n = f.shape[0]
    if np.linalg.matrix_rank(f.transpose(0, 2, 1).reshape(n * n, n)) == n:
        return None  # trivial centre: ad_z = f[:, a, :] z^a = 0 only for z = 0
    try:
        return representation_for(f)
    except RepresentationError:
        return None


def compare_state(
    impl,
    f,
    got_x,
    got_pi,
    ref_x,
    ref_pi,
    ref_Ad,
    tol_abs,
    judge_err=(0.0, 0.0, 0.0),
    ref_G=None,
    rep=None,
):
    """Worst error/tolerance over ``pi``, ``x`` (where it is unique: ``||ad_x||_2 < pi`` at the
    judge's end point, the principal logarithm), ``Ad(g)`` (always; chart-free) and, given
    ``ref_G = rho(g)`` in the faithful representation ``rep``, ``rho(g)`` itself (chart-free and
    faithful: it sees the central part of ``g`` that ``Ad`` cannot).

    A state error ``delta`` in ``x`` moves ``Ad = expm(ad_x)`` by at most
    ``||Ad||_2 ||f||_F ||phi1(-ad_x)||_2 sqrt(n) |delta|_inf`` (left-trivialised derivative of exp:
    ``exp(x + delta) = exp(x) exp(phi1(-ad_x) delta + O(delta^2))``), and ``rho(exp(x))`` by the same
    with ``||rho||_F`` (the norm of the stacked matrices ``rho(e_a)``) for ``||f||_F``."""
    n = f.shape[0]
    ex, ep, ea = (0.0 if v is None else v for v in judge_err[:3])
    eg = 0.0 if len(judge_err) < 4 or judge_err[3] is None else judge_err[3]
    ratios = [max_err(got_pi, ref_pi) / (tol_abs + 2 * ep)]
    if ref_x is not None and np.linalg.norm(ad(f, ref_x), 2) < np.pi:
        ratios.append(max_err(got_x, ref_x) / (tol_abs + 2 * ex))
    if np.all(np.isfinite(got_x)):
        got_Ad = expm(ad(f, got_x))
        amp = (
            np.linalg.norm(ref_Ad, 2)
            * max(np.linalg.norm(f), 1e-300)
            * np.linalg.norm(phi1(-ad(f, got_x)), 2)
        )
        ratios.append(
            max_err(got_Ad, ref_Ad)
            / (
                tol_abs * math.sqrt(n) * max(amp, 1.0)
                + 2 * ea
                + 8
                * n
                * EPS64
                * expm_route(np.abs(ad(f, got_x)).sum(0).max())
                * np.abs(ref_Ad).max()
            )
        )
        if ref_G is not None and rep is not None:
            got_G = rep.exp(got_x)
            r = rep.dim
            amp_g = (
                np.linalg.norm(ref_G, 2)
                * max(float(np.linalg.norm(rep.mats)), 1e-300)
                * np.linalg.norm(phi1(-ad(f, got_x)), 2)
            )
            # expm's own rounding: c r eps exp(||rho(x)||_1) max|G| (its error grows with the norm)
            cond_exp = max(
                math.exp(min(50.0, float(np.linalg.norm(rep.matrix(got_x), 1)))),
                expm_route(float(np.linalg.norm(rep.matrix(got_x), 1))),
            )
            ratios.append(
                max_err(got_G, ref_G)
                / (
                    tol_abs * math.sqrt(n) * max(amp_g, 1.0)
                    + 2 * eg
                    + 8 * r * EPS64 * cond_exp * np.abs(ref_G).max()
                )
            )
    else:
        ratios.append(math.inf)
    return max(ratios)


def reference_work(f, theta, ups, inertia, potential, x, pi, t) -> float:
    """Estimated cost of the mpmath reference flow, before integrating:
    ``|t| (1 + rho) n^3`` with ``rho`` the 2-norm of the vector field's Jacobian at the start
    (float64 central differences of :class:`FloatJudge`): the step count of an extrapolation method grows
    with ``|t| rho``, each step costs ``~ n^3`` multiprecision operations. Upsilon != 0 doubles it."""
    judge = FloatJudge(f, theta, ups, inertia, potential)
    n = judge.n
    Ad0 = expm(ad(judge.f, x))
    z0 = np.concatenate([np.asarray(pi, float), Ad0.ravel()])

    def F(z):
        return judge.rhs(0.0, z, False)[:n]

    h = 1e-6 * max(1.0, float(np.max(np.abs(z0[:n]))))
    J = np.empty((n, n))
    for k in range(n):
        e = np.zeros_like(z0)
        e[k] = h
        J[:, k] = (F(z0 + e) - F(z0 - e)) / (2 * h)
    Om, _ = judge.body(np.asarray(pi, float), Ad0)
    rho = float(np.linalg.norm(J, 2)) + float(np.linalg.norm(ad(judge.f, Om), 2))
    return abs(float(t)) * (1.0 + rho) * n**3 * (2.0 if np.any(judge.U) else 1.0)


DEGENERATE_APPROACH = 1e-6
"""A trajectory whose ``sigma_min(Phi) / sigma_max(Phi)`` falls to this value has reached the degenerate
set Pi_1 (vier7, vier12) to float64 accuracy: the vector field blows up like ``1/Delta`` there and the
flow ends (a correct implementation may return garbage, refuse, or never return)."""


def meets_degenerate_set(f, theta, ups, inertia, pot, x, pi, t) -> bool:
    """Whether the trajectory from ``(x, pi)`` reaches the degenerate set before ``|t|``: the body system
    of :class:`FloatJudge` (``pi`` and ``Ad``) at rtol 1e-8 with a terminal event at
    ``sigma_min(Phi) / sigma_max(Phi) = DEGENERATE_APPROACH``; a failed integration counts as reaching
    it. Never with ``Upsilon = 0`` (``Phi = 1``)."""
    if not np.any(ups) or t == 0:
        return False
    judge = FloatJudge(f, theta, ups, inertia, pot)
    n = judge.n
    y0 = np.concatenate([np.asarray(pi, float), expm(ad(judge.f, x)).ravel()])

    def approach(s, y, w):
        S = np.einsum("m,mab->ab", y[:n], judge.f) - judge.theta
        sv = np.linalg.svd(np.eye(n) + S @ judge.U, compute_uv=False)
        return sv[-1] / sv[0] - DEGENERATE_APPROACH

    approach.terminal = True
    with np.errstate(all="ignore"):
        try:
            sol = solve_ivp(
                judge.rhs,
                (0.0, float(t)),
                y0,
                method="DOP853",
                rtol=1e-8,
                atol=1e-10,
                args=(False,),
                events=approach,
            )
        except (ArithmeticError, np.linalg.LinAlgError, ValueError):
            return True
    return sol.status != 0
