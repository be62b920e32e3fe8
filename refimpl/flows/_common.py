"""Machinery shared by the numpy integrators of :mod:`refimpl.flows.integrators`.

* the starting ``Gamma = Ad(g)^T gamma`` (:func:`gamma0`) and the body systems run by a numpy stepper or
  by generated scalar code (:func:`body_numpy`, :func:`body_scalar`);
* the full state ``(x, pi)`` of vier10/vier11 by a stepper with re-basing of the chart
  (:func:`full_rebased`): ``xdot = L(g, e) Omega`` and ``Gamma = (Ad(g_ref) exp(ad_x))^T gamma``; the
  chart is re-based (``g = g_ref exp(x)``) per trajectory when ``||ad_x||_F > 1``, or after every
  step for the RKMK variants (Munthe-Kaas: the RK method applied in the chart centred at the current
  point); ``x(t)`` is recovered through the faithful representation (:func:`_x_from_rep`,
  :class:`_AbelianPart`);
* su(2) quaternions (:func:`qmul`, :func:`quat_matrix`; :func:`quat_to_x`, :func:`x_to_quat` from
  :mod:`refimpl._flow_compiled`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from .. import _fast_kernels as _fast
from .. import codegen
from .._flow_compiled import quat_to_x, x_to_quat
from .._integrators import ExplicitRK
from .._phi import expm
from .._representation import Representation
from ..model import Model
from .base import FlowResult

__all__ = [
    "body_numpy",
    "body_scalar",
    "full_rebased",
    "full_rhs",
    "gamma0",
    "numpy_rhs",
    "scalar_rhs",
    "qmul",
    "quat_matrix",
    "quat_to_x",
    "x_to_quat",
]

EPS = np.finfo(float).eps


def scalar_rhs(model: Model):
    """The generated body right-hand side alone, ``rhs(t, y) -> list`` (``Upsilon = 0``; for baselines
    such as solve_ivp; :func:`refimpl.codegen.scalar_rhs`)."""
    return codegen.scalar_rhs(model.quadratic_field)


def numpy_rhs(model: Model):
    """The straight-line body right-hand side over numpy rows (:attr:`refimpl.model.Model.numpy_rhs`)."""
    return model.numpy_rhs


def gamma0(model: Model, x0):
    """``Gamma(0) = Ad(exp x0)^T gamma`` (components-first), or None without gravity."""
    if not model.gravity:
        return None
    adx0 = np.einsum("aN,mab->Nmb", x0, model.f)
    Ad0 = _fast._expm_batch(adx0, su2=model.su2)
    return np.einsum("Nmb,m->bN", Ad0, model.gamma)


def body_scalar(model: Model, run, pi0, Gamma0, h, nsteps: int, observe) -> FlowResult:
    """The body system by a generated scalar ``run(y0: list, h, nsteps, rec)``, one trajectory at a
    time (Python floats: no numpy scalars); observed samples are replayed in step order, batched."""
    n, N = pi0.shape
    y0 = pi0 if Gamma0 is None else np.concatenate([pi0, Gamma0])
    res = np.empty_like(y0)
    hist = np.empty((nsteps, y0.shape[0], N)) if observe is not None else None
    for j in range(N):
        rec = (
            None
            if hist is None
            else (lambda k, y, j=j: hist.__setitem__((k - 1, slice(None), j), y))
        )
        res[:, j] = run(y0[:, j].tolist(), h, nsteps, rec)
    if hist is not None:
        for k in range(nsteps):
            observe(k + 1, hist[k, :n], None if Gamma0 is None else hist[k, n:], None)
    return _body_result(res, n, Gamma0)


def _body_result(y, n, Gamma0) -> FlowResult:
    return FlowResult(
        pi=y[:n],
        Gamma=None if Gamma0 is None else y[n:],
        rebases=np.zeros(y.shape[1], dtype=int),
    )


def body_observer(observe, n, Gamma0):
    """``observe(k, pi, Gamma, None)`` from a stepper's ``obs(k, y)`` on the body state."""
    if observe is None:
        return None
    return lambda k, y: observe(k, y[:n], None if Gamma0 is None else y[n:], None)


def body_numpy(model: Model, stepper, pi0, Gamma0, t, nsteps: int, observe) -> FlowResult:
    """The body system by a batched numpy ``stepper`` (:mod:`refimpl._integrators`); explicit RK on the
    polynomial field (``Upsilon = 0``) writes the field into its stage buffers."""
    n = pi0.shape[0]
    F = model.body_rhs()
    y0 = pi0 if Gamma0 is None else np.concatenate([pi0, Gamma0])
    obs = body_observer(observe, n, Gamma0)
    if isinstance(stepper, ExplicitRK) and model.upsilon_zero:
        y = stepper.integrate(F, y0, t, nsteps, observe=obs, F_into=model.numpy_rhs_inplace)
    else:
        y = stepper.integrate(F, y0, t, nsteps, observe=obs)
    return _body_result(y, n, Gamma0)


def full_rhs(model: Model, Ad_ref):
    """``(x, pi)`` field; ``Ad_ref`` (N, n, n) is read at call time (re-basing updates it in place)."""
    n = model.n

    def F(y):
        x, pi = y[:n], y[n:]
        adx = np.einsum("aN,mab->Nmb", x, model.f)
        Gamma = None
        if model.gravity:
            Ad = Ad_ref @ _fast._expm_batch(adx, su2=model.su2)
            Gamma = np.einsum("Nmb,m->bN", Ad, model.gamma)
        Omega, pidot = model.omega_pidot(pi, Gamma)
        L = _frame_L(adx, model.su2)
        xdot = np.einsum("Nab,bN->aN", L, Omega)
        return np.concatenate([xdot, pidot])

    return F


def _frame_L(adx, su2):
    if su2:
        t2 = -0.5 * np.einsum("Nij,Nji->N", adx, adx)
        c, _, _, _ = _fast._su2_frame_coeffs(t2)
        return np.eye(3)[None] + 0.5 * adx + c[:, None, None] * (adx @ adx)
    return _fast._frames_generic(adx)[0]


def full_rebased(
    model: Model, stepper, x0, pi0, t, nsteps: int, *, rkmk: bool, observe
) -> FlowResult:
    """The full state ``(x, pi)`` by a numpy ``stepper`` with re-basing (module docstring)."""
    n, N = pi0.shape
    Ad_ref = np.broadcast_to(np.eye(n), (N, n, n)).copy()
    rebases = np.zeros(N, dtype=int)
    q_ref = np.zeros((4, N)) if model.su2 else None
    if q_ref is not None:
        q_ref[0] = 1.0
    rep = model.representation if q_ref is None else None
    G_ref = (
        None
        if rep is None
        else np.broadcast_to(np.eye(rep.dim, dtype=rep.mats.dtype), (N, rep.dim, rep.dim)).copy()
    )
    # exponential algebras: the abelian part of x is accumulated across re-basings (see _AbelianPart)
    ab = _AbelianPart.of(model.f, N) if (rep is not None and rep.exponential) else None
    F = full_rhs(model, Ad_ref)
    # nilpotent algebras: exp is a global diffeomorphism and phi1(-ad_x) never degenerates -> no re-basing
    threshold = np.inf if (rep is not None and rep.nilpotent) else (0.0 if rkmk else 1.0)

    def after(y):
        x = y[:n]
        adx = np.einsum("aN,mab->Nmb", x, model.f)
        r = np.sqrt(np.sum(adx * adx, axis=(1, 2)))
        move = r > threshold
        if move.any():
            Ad_ref[move] = Ad_ref[move] @ _fast._expm_batch(adx[move], su2=model.su2)
            if q_ref is not None:
                q_ref[:, move] = qmul(q_ref[:, move], x_to_quat(x[:, move]))
            if G_ref is not None:
                G_ref[move] = G_ref[move] @ rep.exp(x[:, move].T)
            if ab is not None:
                ab.s[:, move] += ab.P @ x[:, move]
            y = y.copy()
            y[:n, move] = 0.0
            rebases[move] += 1
        return y

    def obs(k, y):
        x = y[:n]
        adx = np.einsum("aN,mab->Nmb", x, model.f)
        Ad = Ad_ref @ _fast._expm_batch(adx, su2=model.su2)
        G = np.einsum("Nmb,m->bN", Ad, model.gamma) if model.gravity else None
        if q_ref is not None:
            xs = quat_to_x(qmul(q_ref, x_to_quat(x)))
        else:
            xs = _x_from_rep(model, rep, G_ref, x, Ad, rebases, ab)
        observe(k, y[n:], G, xs)

    y0 = np.concatenate([x0, pi0])
    y = stepper.integrate(
        F, y0, t, nsteps, after_step=after, observe=obs if observe is not None else None
    )
    x = y[:n]
    adx = np.einsum("aN,mab->Nmb", x, model.f)
    Ad = Ad_ref @ _fast._expm_batch(adx, su2=model.su2)
    G = np.einsum("Nmb,m->bN", Ad, model.gamma) if model.gravity else None
    quat = None if q_ref is None else qmul(q_ref, x_to_quat(x))
    if quat is not None:
        xs = np.where(rebases[None] == 0, x, quat_to_x(quat))
        g = quat_matrix(quat)
    else:
        xs = _x_from_rep(model, rep, G_ref, x, Ad, rebases, ab)
        g = G_ref @ rep.exp(x.T)
    return FlowResult(
        pi=y[n:], Gamma=G, x_local=x, Ad_ref=Ad_ref, Ad=Ad, quat=quat, x=xs, g=g, rebases=rebases
    )


def qmul(a, b):
    """Hamilton product of quaternions (4, N): the product of the su(2) matrices ``q0 - i qv.sigma``."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[0] = a[0] * b[0] - np.sum(a[1:] * b[1:], axis=0)
    out[1:] = a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:], axis=0)
    return out


def quat_matrix(q):
    """The SU(2) matrix ``q0 - i qv.sigma`` (the catalogue's representation ``E_a = -(i/2) sigma_a``) of
    quaternions (4, N): (N, 2, 2) complex."""
    q0, q1, q2, q3 = q
    return np.stack(
        [np.stack([q0 - 1j * q3, -1j * q1 - q2], -1), np.stack([-1j * q1 + q2, q0 + 1j * q3], -1)],
        -2,
    )


def _x_from_rep(model, rep: Representation, G_ref, x, Ad, rebases, ab=None):
    """``x`` with ``g = exp(x)``: the chart coordinate itself for trajectories never re-based (then
    ``||ad_x||_F <= 1``, well inside the principal strip, or the algebra is nilpotent), else the
    logarithm of ``g = g_ref exp(x)`` chosen by :meth:`Representation.log` (principal logarithm in
    ``rho``, else of ``Ad(g)`` corrected by the centre, documented choice on the cut locus); on
    exponential algebras its abelian part is then replaced by the accumulated one (``ab``,
    :class:`_AbelianPart`)."""
    out = x.copy()
    for j in np.flatnonzero(rebases):
        if not (np.all(np.isfinite(x[:, j])) and np.all(np.isfinite(Ad[j]))):
            out[:, j] = np.nan  # a diverged run (too few steps): the caller refines or reports it
            continue
        g = G_ref[j] @ rep.exp(x[:, j])
        out[:, j] = rep.log(g, Ad[j])
        if ab is not None:
            out[:, j] = ab.refine(rep, g, out[:, j], ab.s[:, j] + ab.P @ x[:, j])
    return out


class _AbelianPart:
    """The abelian part ``p(x)`` of ``x = log g`` on exponential (completely solvable) algebras.

    Why: ``log`` is ill-conditioned there once ``ad_x`` has a large real eigenvalue ``l``: ``g`` then
    carries ``x`` partly through ``e^-|l|`` (measured on Bianchi III with a cocycle at T = 10:
    ``l = -27``, ``g``'s entries ``0.5 +- 0.5 e^l``, so float64 ``g`` fixes ``x`` to 6 digits while
    ``g`` itself is right to 11.5). The quotient ``p: g -> g/[g, g]`` is a homomorphism onto an
    abelian algebra, so ``P(g_ref exp(x)) = P(g_ref) + p(x)``: the abelian part is the sum of the
    local charts' parts, accumulated at every re-basing with no logarithm. ``P`` (rows) spans the
    annihilator of ``[g, g]``. The rest of ``x`` (its part in ``[g, g]``, where the exponential is
    well conditioned) is then fitted to ``g`` by Gauss-Newton steps with that abelian part held
    fixed (:meth:`refine`); the result still satisfies ``exp(x) = g`` to the log's own accuracy."""

    def __init__(self, P, D, N):
        self.P, self.D = P, D
        self.s = np.zeros((P.shape[0], N))

    @classmethod
    def of(cls, f, N):
        n = f.shape[0]
        U, sv, _ = np.linalg.svd(np.asarray(f, float).reshape(n, n * n))
        r = int(np.sum(sv > 1e-9 * max(1.0, sv[0] if sv.size else 0.0)))
        if r in (0, n):  # abelian (the log is exact) or perfect (no abelian part)
            return None
        return cls(U[:, r:].T.copy(), U[:, :r].copy(), N)

    def refine(self, rep: Representation, G, x, s):
        """``x`` with ``P x = s`` and ``exp(rho(x))`` closest to ``G`` (Gauss-Newton over ``[g, g]``);
        ``x`` itself when the fit does not beat it."""
        x0 = np.asarray(x, float)
        y = x0 + np.linalg.pinv(self.P) @ (s - self.P @ x0)
        Dr = np.einsum("ak,aij->kij", self.D, rep.mats)

        def resid(v):
            return expm(rep.matrix(v)) - G

        best, r_best = y, resid(y)
        for _ in range(8):
            X = rep.matrix(best)
            Jc = np.stack([scipy.linalg.expm_frechet(X, E, compute_expm=False) for E in Dr], -1)
            Jr = Jc.reshape(-1, Jc.shape[-1])
            if np.iscomplexobj(Jr):
                Jr = np.concatenate([Jr.real, Jr.imag])
                rr = np.concatenate([r_best.real.ravel(), r_best.imag.ravel()])
            else:
                rr = r_best.ravel()
            dw, *_ = np.linalg.lstsq(Jr, -rr, rcond=None)
            cand = best + self.D @ dw
            r_c = resid(cand)
            if not np.max(np.abs(r_c)) < np.max(np.abs(r_best)):
                break
            best, r_best = cand, r_c
        ok = np.max(np.abs(r_best)) <= np.max(np.abs(resid(x0))) * 10 + 1e3 * EPS * max(
            1.0, float(np.max(np.abs(G)))
        )
        return best if ok else x0
