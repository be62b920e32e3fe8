"""Fast flows: numpy float64, batched over many initial conditions, structure-aware.

State layout is components-first: ``y`` of shape ``(d, N)`` for ``N``
trajectories. Systems (same mathematics as :mod:`refimpl._flow_reference`,
written independently in numpy):

``body``
    ``(pi)`` when ``V = 0`` (Euler, twee14/drie6) or ``(pi, Gamma)`` with
    gravity (Euler-Poisson, twee17 sign-corrected, twee18; vier10/vier11 in
    general): no configuration is integrated.
``full``
    ``(x, pi)`` of vier10/vier11 with ``xdot = L(g, e) Omega`` and
    ``Gamma = (Ad(g_ref) exp(ad_x))^T gamma``; the chart is re-based
    (``g = g_ref exp(x)``) per trajectory when ``||ad_x||_F > 1``, or after
    every step for the RKMK variant (Munthe-Kaas: the RK method is applied in
    the chart centred at the current point).

Methods (the registry :mod:`refimpl.integrators`, one module per family; each declares ``order``,
fitted by ``tests/test_flow_orders.py``):

* ``taylor``: adaptive Taylor, compiled (numba, :mod:`refimpl._compiled_taylor`): Jorba-Zou order and
  step from a tolerance, per trajectory; on su(2)/so(3) the full state carries the group element as a
  quaternion (:mod:`refimpl._flow_compiled`); the default of :func:`fast_flow` when numba is present;
* ``dop853``: fixed-step explicit RK of order 8 (Dormand-Prince tableau);
  with ``Upsilon = 0`` the body field is generated straight-line code
  (code generation section at the end of this module); ``dop853-scalar`` runs the same method as
  generated scalar Python for single trajectories;
* ``rk4`` / ``rkmk4``, ``rkmk8``: Lie-group (RKMK) variants re-basing every step;
* ``midpoint``, ``gauss4``, ``gauss6``: Gauss-Legendre collocation (orders
  2, 4, 6) for general ``omega_L`` (``Upsilon != 0``);
* ``taylor12/16/20/24``: Taylor series of order 12-24 for the polynomial body
  systems (``Upsilon = 0``): Cauchy-product recurrences for the Taylor
  coefficients of the quadratic field (:mod:`refimpl._taylor`); the compiled
  kernel of :mod:`refimpl._compiled_taylor` when numba is importable, else
  generated scalar code for up to :data:`TAYLOR_SCALAR_MAX` trajectories and
  batched numpy ``einsum`` kernels beyond (also used when steps are observed);
* ``splitting2/4/6``: Lie-Poisson splitting for su(2)/so(3) with diagonal
  inertia, ``Upsilon = 0``, any ``Theta`` and gravity. ``H = sum_i H_i + V``
  with ``H_i = (pi'_i - xi_i)^2 / 2 I_i`` (``pi' = pi + xi``, drie7, drie10):
  under ``H_i`` the vectors ``pi'`` and ``Gamma`` rotate about ``e_i`` by
  ``-Omega_i t`` and ``g -> g exp(t Omega_i e_i)``, exactly; under ``V`` only
  ``pi`` moves, by ``t L x Gamma``. Strang's symmetric composition (order 2)
  raised by the triple jump (orders 4, 6). Each sub-flow is a Poisson map, so
  the Casimirs ``|pi'|^2`` or ``|Gamma|^2``, ``pi.Gamma`` (for ``xi = 0``)
  are kept to rounding and ``g`` stays on the group (a unit quaternion).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg

from . import _compiled_taylor as _ct
from . import _fast_kernels as _fast
from . import codegen
from ._algebra import LieAlgebra
from ._compiled_rational import rational_taylor_body
from ._flow_compiled import (
    compiled_taylor_body,
    compiled_taylor_flow,
    compiled_taylor_samples,
    quat_to_x,
    supports_full,
    x_to_quat,
)
from ._flow_reference import check_time
from ._integrators import DOP853, ExplicitRK, GaussLegendre, triple_jump_weights
from ._lru import LRU
from ._representation import Representation, representation_for
from ._taylor import numpy_taylor_integrator, scalar_taylor_integrator
from ._validate import (
    check_flow_rates,
    check_flow_request,
    check_points,
)
from .integrators import METHODS, Method
from .model import Model

__all__ = ["METHODS", "TAYLOR_SCALAR_MAX", "Method", "NumpyModel", "integrate_fast", "method"]

EPS = np.finfo(float).eps
TAYLOR_SCALAR_MAX = (
    16  # up to this many trajectories the Taylor methods run generated scalar code: the numpy
)
# kernel's fixed cost per step (~20 calls per order) matched the scalar code's between 16 and 32 heavy tops


NumpyModel = Model
"""The validated float64 model (:class:`refimpl.model.Model`; the old name, kept)."""


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


# -------------------------------------------------------------- methods
# The methods come from the registry (refimpl.integrators: one module per family, each method a class
# declaring its order, kind and applies(model)).
_STEPPERS = {name: m.stepper for name, m in METHODS.items() if m.stepper is not None}


def method(name: str) -> Method:
    if name not in METHODS:
        raise ValueError(f"unknown flow method {name!r}; known: {sorted(METHODS)}")
    return METHODS[name]


# ------------------------------------------------------ splitting (su(2))
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


def qmul(a, b):
    """Hamilton product of quaternions (4, N): the product of the su(2) matrices ``q0 - i qv.sigma``."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[0] = a[0] * b[0] - np.sum(a[1:] * b[1:], axis=0)
    out[1:] = a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:], axis=0)
    return out


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


def _splitting_integrate(model: NumpyModel, pi, Gamma, quat, t, nsteps, order, observe=None):
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


# ------------------------------------------------------------ integrate
def integrate_fast(
    model: NumpyModel,
    meth: Method,
    x0,
    pi0,
    t,
    nsteps: int | None,
    *,
    system: str,
    observe=None,
    tol: float | None = None,
):
    """Integrate ``N`` trajectories (``x0``, ``pi0`` of shape (n, N)) to time ``t`` in ``nsteps`` steps.

    Returns a dict with ``pi``, ``Gamma`` (or None), ``x`` (or None), ``Ad`` (N, n, n, or None),
    ``quat`` (su(2) splitting only), ``rebases`` (per trajectory). The adaptive methods
    (``meth.adaptive``) take ``tol`` instead of ``nsteps``: a local tolerance on the body system, the
    global one on the full state (:func:`refimpl._flow_compiled.compiled_taylor_flow`).
    """
    ok, why = meth.applies(model)
    if not ok:
        raise ValueError(f"method {meth.name} does not apply: {why}")
    n, N = pi0.shape
    if meth.adaptive:
        if tol is None:
            raise ValueError(
                f"method {meth.name} is adaptive: give tol (a tolerance), not a step count"
            )
        tol = check_tolerance(tol)
        if observe is not None:
            raise ValueError(f"method {meth.name} is adaptive: it has no fixed steps to observe")
        if meth.kind == "taylor-rational":  # Upsilon != 0 (refimpl._compiled_rational)
            if system == "body":
                return rational_taylor_body(model, x0, pi0, t, tol=tol)
            if not model.su2:
                raise ValueError(
                    f"method {meth.name} integrates the full state on su(2)/so(3) only (the "
                    "configuration as a quaternion); use system='body' or a re-basing method"
                )
            return compiled_taylor_flow(model, x0, pi0, t, tol)
        if system == "body":
            return compiled_taylor_body(model, x0, pi0, t, tol=tol)
        if not supports_full(model):
            raise ValueError(
                f"method {meth.name} integrates the full state on su(2)/so(3) only; "
                "use system='body' or a re-basing method"
            )
        return compiled_taylor_flow(model, x0, pi0, t, tol)
    if meth.kind == "taylor" and system == "body" and observe is None and _ct.HAVE_NUMBA:
        return compiled_taylor_body(model, x0, pi0, t, order=meth.order, nsteps=nsteps)
    adx0 = np.einsum("aN,mab->Nmb", x0, model.f)
    Ad0 = _fast._expm_batch(adx0, su2=model.su2)
    Gamma0 = np.einsum("Nmb,m->bN", Ad0, model.gamma) if model.gravity else None
    if meth.kind in ("scalar", "taylor"):
        if system != "body":
            raise ValueError(f"method {meth.name} integrates body systems only (no configuration)")
        y0 = pi0 if Gamma0 is None else np.concatenate([pi0, Gamma0])
        h = t / nsteps
        if meth.kind == "taylor" and N > TAYLOR_SCALAR_MAX:
            obs = (
                None
                if observe is None
                else (lambda k, y: observe(k, y[:n], None if Gamma0 is None else y[n:], None))
            )
            res = numpy_taylor_integrator(model, meth.order)(y0, h, nsteps, observe=obs)
        else:
            if meth.kind == "taylor":
                run = scalar_taylor_integrator(model, meth.order)
            else:
                run = scalar_rk_integrator(model, (DOP853.A, DOP853.b, DOP853.c))
            res = np.empty_like(y0)
            hist = np.empty((nsteps, y0.shape[0], N)) if observe is not None else None
            for j in range(N):
                rec = (
                    None
                    if hist is None
                    else (lambda k, y, j=j: hist.__setitem__((k - 1, slice(None), j), y))
                )
                res[:, j] = run(
                    y0[:, j].tolist(), h, nsteps, rec
                )  # Python floats: no numpy scalars
            if hist is not None:  # replay the samples in step order, batched like the other methods
                for k in range(nsteps):
                    observe(k + 1, hist[k, :n], None if Gamma0 is None else hist[k, n:], None)
        return {
            "pi": res[:n],
            "Gamma": None if Gamma0 is None else res[n:],
            "x": None,
            "Ad": None,
            "quat": None,
            "rebases": np.zeros(N, dtype=int),
        }
    if meth.kind == "splitting":
        pi = pi0.copy()
        G = None if Gamma0 is None else Gamma0.copy()
        quat = x_to_quat(x0) if system == "full" else None
        _splitting_integrate(model, pi, G, quat, t, nsteps, meth.order, observe=observe)
        out = {
            "pi": pi,
            "Gamma": G,
            "x": None if quat is None else quat_to_x(quat),
            "quat": quat,
            "g": None if quat is None else quat_matrix(quat),
            "Ad": None,
            "rebases": np.zeros(N, dtype=int),
        }
        return out
    stepper: ExplicitRK | GaussLegendre = meth.stepper
    if system == "body":
        F = model.body_rhs()
        y0 = pi0 if Gamma0 is None else np.concatenate([pi0, Gamma0])
        obs = (
            None
            if observe is None
            else (lambda k, y: observe(k, y[:n], None if Gamma0 is None else y[n:], None))
        )
        if isinstance(stepper, ExplicitRK) and model.upsilon_zero:
            y = stepper.integrate(F, y0, t, nsteps, observe=obs, F_into=numpy_rhs_inplace(model))
        else:
            y = stepper.integrate(F, y0, t, nsteps, observe=obs)
        return {
            "pi": y[:n],
            "Gamma": None if Gamma0 is None else y[n:],
            "x": None,
            "Ad": None,
            "quat": None,
            "rebases": np.zeros(N, dtype=int),
        }
    Ad_ref = np.broadcast_to(np.eye(n), (N, n, n)).copy()
    rebases = np.zeros(N, dtype=int)
    q_ref = np.zeros((4, N)) if model.su2 else None
    if q_ref is not None:
        q_ref[0] = 1.0
    rep = _rep_of(model) if q_ref is None else None
    G_ref = (
        None
        if rep is None
        else np.broadcast_to(np.eye(rep.dim, dtype=rep.mats.dtype), (N, rep.dim, rep.dim)).copy()
    )
    # exponential algebras: the abelian part of x is accumulated across re-basings (see _AbelianPart)
    ab = _AbelianPart.of(model.f, N) if (rep is not None and rep.exponential) else None
    F = full_rhs(model, Ad_ref)
    # nilpotent algebras: exp is a global diffeomorphism and phi1(-ad_x) never degenerates -> no re-basing
    threshold = np.inf if (rep is not None and rep.nilpotent) else (0.0 if meth.rkmk else 1.0)

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
    return {
        "pi": y[n:],
        "Gamma": G,
        "x_local": x,
        "Ad_ref": Ad_ref,
        "Ad": Ad,
        "quat": quat,
        "x": xs,
        "g": g,
        "rebases": rebases,
    }


def quat_matrix(q):
    """The SU(2) matrix ``q0 - i qv.sigma`` (the catalogue's representation ``E_a = -(i/2) sigma_a``) of
    quaternions (4, N): (N, 2, 2) complex."""
    q0, q1, q2, q3 = q
    return np.stack(
        [np.stack([q0 - 1j * q3, -1j * q1 - q2], -1), np.stack([-1j * q1 + q2, q0 + 1j * q3], -1)],
        -2,
    )


def _rep_of(model) -> Representation:
    """The faithful matrix representation ``E_a`` of the model's algebra (:mod:`refimpl._representation`:
    the algebra's own or an exact catalogue match's, else built from ``f`` and cached). Raises
    :class:`refimpl._representation.RepresentationError` naming the condition when none can be built."""
    return representation_for(model.algebra if model.algebra is not None else model.f)


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
            return scipy.linalg.expm(rep.matrix(v)) - G

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


# ------------------------------------------------------ generated code (refimpl.codegen)
def scalar_rk_integrator(model, tableau):
    """A function ``run(y0: list, h, nsteps, observe=None) -> list`` for one trajectory: the explicit RK
    ``tableau`` unrolled around the generated body field (:func:`refimpl.codegen.scalar_rk`)."""
    key = (
        model.f.tobytes(),
        model.theta.tobytes(),
        model.Iinv.tobytes(),
        None if not model.gravity else model.Lvec.tobytes(),
        np.asarray(tableau[0]).tobytes(),
    )
    return _SCALAR_RK.get(key, lambda: codegen.scalar_rk(model.quadratic_field, tableau))


_SCALAR_RK = LRU(64)  # generated scalar RK functions, keyed on the numbers


def scalar_rhs(model):
    """The generated body right-hand side alone, ``rhs(t, y) -> list`` (for baselines such as
    solve_ivp; :func:`refimpl.codegen.scalar_rhs`)."""
    return codegen.scalar_rhs(model.quadratic_field)


def numpy_rhs(model):
    """The straight-line body right-hand side over numpy rows (:attr:`refimpl.model.Model.numpy_rhs`)."""
    return model.numpy_rhs


def numpy_rhs_inplace(model):
    """``rhs(y, out)``: the body field written into ``out`` (:attr:`refimpl.model.Model.numpy_rhs_inplace`)."""
    return model.numpy_rhs_inplace


# ------------------------------------------------------------ protocol flow and trajectories
def check_tolerance(tol) -> float:
    try:
        v = float(tol)
    except (TypeError, ValueError):
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}")
    return v


_MODELS = LRU(
    64
)  # validated models kept (keyed on the bytes of the inputs), least recently used dropped


def _numeric_key(a):
    """``(dtype, shape, bytes)`` of a plain numeric array-like, or None (not cacheable: object arrays,
    LieAlgebra instances, strings; those take the uncached route through full validation)."""
    if isinstance(a, LieAlgebra):
        return None
    try:
        arr = np.asarray(a)
    except Exception:  # noqa: BLE001 - anything odd is validated (and refused by name) uncached
        return None
    if arr.dtype.kind not in "fiub":
        return None
    return (arr.dtype.str, arr.shape, arr.tobytes())


def _potential_key(potential):
    if potential is None:
        return ("none",)
    if not (isinstance(potential, dict) and set(potential) == {"kind", "L", "gamma"}):
        return None
    kind, L, gamma = (
        potential["kind"],
        _numeric_key(potential["L"]),
        _numeric_key(potential["gamma"]),
    )
    if not isinstance(kind, str) or L is None or gamma is None:
        return None
    return (kind, L, gamma)


def cached_model(f, theta, upsilon, inertia, potential) -> NumpyModel:
    """The validated :class:`NumpyModel`, cached on the bytes (dtype, shape, values) of the inputs.

    Validation is a function of the values alone, so a model whose inputs carry the same bytes as an
    earlier one is that model: the second call skips validation and preparation (inverse inertia,
    su(2) detection, compiled fields). Inputs that are not plain numeric arrays are validated afresh
    every time. The caller's arrays are only read (their bytes copied into the key)."""
    keys = [_numeric_key(a) for a in (f, theta, upsilon, inertia)] + [_potential_key(potential)]
    if any(k is None for k in keys):
        return NumpyModel(f, theta, upsilon, inertia, potential)
    return _MODELS.get(tuple(keys), lambda: Model(f, theta, upsilon, inertia, potential))


def _points(x0, pi0, n: int):
    """:func:`check_points` (batched), with a shortcut for float64 arrays of the right shape whose
    entries are all finite (nothing to convert or report; anything else gets the full check and its
    messages). The arrays are returned as given: callers copy before writing."""
    if (
        type(x0) is np.ndarray
        and type(pi0) is np.ndarray
        and x0.dtype == np.float64
        and pi0.dtype == np.float64
        and x0.shape == pi0.shape
        and x0.shape[-1:] == (n,)
        and np.isfinite(x0).all()
        and np.isfinite(pi0).all()
    ):
        return x0, pi0
    return check_points(x0, pi0, n, batched=True)


def _check_rates(model: NumpyModel, pa, tv: float) -> None:
    """:func:`check_flow_rates` on the cached model: its inputs ``||I^-1||_2`` and ``max|f|`` are
    computed once per model; the check itself runs (and raises, naming the point) only when the same
    bound, evaluated here on ``max |pi|`` over the batch, could exceed the budget."""
    c = model.rate_const
    size = float(np.max(np.abs(pa))) * math.sqrt(model.n) if pa.size else 0.0
    if not abs(tv) * c * max(1.0, size) <= 0.5 * 2.0**14 * (2 + abs(tv)):  # half the budget: margin
        check_flow_rates(model.f, model.inertia, pa, tv)


def _default_method(model: NumpyModel, *, full: bool = False) -> Method:
    """The fastest method meeting a tolerance: the compiled adaptive Taylor method on the su(2) full
    state (``full``) when numba is present (``taylor``, or ``taylor-rational`` when ``Upsilon != 0``),
    else DOP853 (``Upsilon = 0``) or Gauss6 (``Upsilon != 0``)."""
    if full and _ct.HAVE_NUMBA and supports_full(model):
        return METHODS["taylor"] if model.upsilon_zero else METHODS["taylor-rational"]
    return METHODS["dop853"] if model.upsilon_zero else METHODS["gauss6"]


def fast_flow(
    f,
    theta,
    upsilon,
    inertia,
    potential,
    x0,
    pi0,
    t,
    *,
    method_name: str | None = None,
    steps: int | None = None,
    tol: float = 1e-10,
    return_group: bool = False,
):
    """Protocol method 3, batched: ``(x, pi)`` at time ``t`` for every initial point.

    ``method_name``: a key of :data:`METHODS` (default on su(2)/so(3) when numba is importable: the
    compiled adaptive Taylor method, ``taylor`` for ``Upsilon = 0`` and ``taylor-rational`` otherwise --
    its two-run control keeps every trajectory's error in ``pi`` and ``Ad(g)`` below ``tol``, see
    :mod:`refimpl._flow_compiled` -- else ``dop853``, or ``gauss6`` when ``Upsilon != 0``). ``steps``: a fixed step count; by
    default steps are doubled from ``8 + 4 t`` until the runs with ``N`` and
    ``2N`` steps differ by at most ``tol * (2^p - 1)`` (Richardson: the
    error of the finer run is then below ``tol``) on every trajectory.
    ``t`` may be negative (the flow backwards). ``x(t)`` always exists: the chart is re-based through
    the algebra's faithful representation (:mod:`refimpl._representation`) and ``x(t)`` is the
    logarithm of ``g(t)`` documented there (principal where it exists). ``return_group=True`` also
    returns ``g(t)`` as matrices of that representation, shape batch + ``(r, r)``
    (:func:`refimpl._representation.representation_for` gives the representation).
    Raises ``ValueError`` for bad ``t``/``tol`` (NaN, infinite, non-real), starting points on the
    degenerate set (naming them), trajectories that reach it, and algebras whose representation
    cannot be built (:class:`refimpl._representation.RepresentationError`).
    """
    # plain float t: the exact conversion of check_time is the identity (the same checks, no mpmath)
    tv = float(t) if type(t) in (float, np.float64) and math.isfinite(t) else None
    tv = check_time(t, allow_negative=True) if tv is None else tv
    tol = check_tolerance(tol)
    check_flow_request(tv, tol, steps, method_name, METHODS)  # issue 15 hook: the stated budget
    model = cached_model(f, theta, upsilon, inertia, potential)
    n = model.n
    xa, pa = _points(x0, pi0, n)
    if steps is None:  # issue 15 hook: refuse points too fast for the step-doubling budget
        _check_rates(model, pa, tv)
    shape = xa.shape[:-1]
    X = np.ascontiguousarray(xa.reshape(-1, n).T)
    P = np.ascontiguousarray(pa.reshape(-1, n).T)
    _check_start(model, P)
    if method_name is not None:
        method(method_name)
    meth = (
        METHODS[method_name]
        if method_name is not None
        else _default_method(model, full=steps is None)
    )
    if tv == 0:
        if return_group:
            g0 = _group_of(model, X)
            return xa.copy(), pa.copy(), g0.reshape(shape + g0.shape[1:])
        return xa.copy(), pa.copy()
    if meth.adaptive:
        if steps is not None:
            raise ValueError(f"method {meth.name} is adaptive: give tol, not steps")
        out = integrate_fast(model, meth, X, P, tv, None, system="full", tol=tol)
    elif steps is not None:
        if not isinstance(steps, (int, np.integer)) or steps < 1:
            raise ValueError(f"steps must be a positive int, got {steps!r}")
        out = integrate_fast(model, meth, X, P, tv, int(steps), system="full")
    else:
        N = int(8 + 4 * np.ceil(abs(tv)))

        def run(N):
            # too coarse a step can make an implicit stage iteration diverge, or carry a stage
            # onto a singular Phi: that run is discarded (None) and the steps doubled again
            try:
                with np.errstate(all="ignore"):
                    res = integrate_fast(model, meth, X, P, tv, N, system="full")
            except (np.linalg.LinAlgError, FloatingPointError):
                return None
            return res if np.all(np.isfinite(res["pi"])) else None

        prev, failed = run(N), 0
        for _ in range(14):
            N *= 2
            out = run(N)
            if out is None or prev is None:
                failed += out is None
                if failed >= 3:  # a regular trajectory stops failing once the steps are fine
                    raise ValueError(
                        f"fast_flow: {failed} runs (up to {N} steps) diverged or met a singular "
                        f"Phi before t = {tv}: the trajectory reaches or grazes the degenerate set "
                        "Pi_1 (vier12)"
                    )
                prev = out
                continue
            diff = np.max(
                np.abs(np.concatenate([out["pi"] - prev["pi"], _xdiff(out, prev)])), axis=0
            )
            if np.all(diff <= tol * (2**meth.order - 1)):
                break
            prev = out
        else:
            why = (
                f" ({failed} runs diverged or met a singular Phi: the trajectory may reach the "
                "degenerate set Pi_1, vier12)"
                if failed
                else ""
            )
            raise ValueError(f"fast_flow: tolerance {tol} not reached with {N} steps{why}")
    bad_pi = ~np.all(np.isfinite(out["pi"]), axis=0)
    if np.any(bad_pi):
        raise ValueError(
            f"fast_flow: trajectories {np.flatnonzero(bad_pi)[:10].tolist()} became non-finite before t = {tv} "
            "(they reached the degenerate set Pi_1, vier12, or diverged); no point is dropped"
        )
    x = out["x"]
    if np.any(~np.isfinite(x)):
        bad = np.argwhere(~np.all(np.isfinite(x), axis=0)).ravel()
        raise ValueError(
            f"fast_flow: no logarithm x(t) of g(t) found for trajectories {bad[:10].tolist()}"
        )
    xs, ps = x.T.reshape(shape + (n,)), out["pi"].T.reshape(shape + (n,))
    if return_group:
        g = out.get("g")
        if g is None:  # the compiled su(2) paths carry the quaternion: g is its SU(2) matrix
            g = quat_matrix(out["quat"]) if out.get("quat") is not None else _group_of(model, x)
        return xs, ps, g.reshape(shape + g.shape[1:])
    return xs, ps


def _group_of(model, X):
    """``rho(exp(x))`` for X (n, N): (N, r, r) in the representation the flows use."""
    if model.su2:
        return quat_matrix(x_to_quat(X))
    return _rep_of(model).exp(X.T)


def _xdiff(a, b):
    if a.get("Ad") is not None:
        return (a["Ad"] - b["Ad"]).reshape(a["Ad"].shape[0], -1).T
    return a["x"] - b["x"]


def _check_start(model: NumpyModel, P: np.ndarray) -> None:
    """Starting points on the degenerate set (``Delta = 0`` to float64 accuracy, vier12) are refused."""
    if model.upsilon_zero:
        return
    res = _fast.FastCore().poisson_batch(
        model.f, model.theta, model.upsilon, np.zeros_like(P.T), P.T
    )
    if np.any(res.degenerate):
        idx = np.argwhere(res.degenerate).ravel()
        raise ValueError(
            f"initial point(s) {idx[:10].tolist()} lie on the degenerate set Pi_1 (Delta = det Phi = 0 to float64 "
            f"accuracy, vier12): no flow exists there"
        )


def fast_trajectory(
    f,
    theta,
    upsilon,
    inertia,
    potential,
    x0,
    pi0,
    t_end,
    samples: int,
    steps_per_sample: int,
    *,
    method_name=None,
    system: str = "full",
    progress=None,
    tol: float | None = None,
):
    """A batch ``(N, n)`` sampled at ``samples`` equally spaced times in ``[0, t_end]``.

    Returns a dict: ``times`` (T,), ``pi`` (T, N, n), ``Gamma`` (T, N, n) or
    None, ``x`` (T, N, n) with ``exp(x) = g`` (the logarithm of :mod:`refimpl._representation`)
    or None for ``system="body"``, ``g`` (T, N, r, r): ``g(t)`` in the algebra's faithful
    representation (None for ``system="body"``), and the method used. ``t_end`` may be negative.
    """
    tv = check_time(t_end, "t_end", allow_negative=True)
    if tv == 0:
        raise ValueError("t_end must be non-zero for a trajectory")
    adaptive = method_name in METHODS and METHODS[method_name].adaptive
    if samples < 2 or (steps_per_sample < 1 and not adaptive):
        raise ValueError(
            f"samples must be >= 2 and steps_per_sample >= 1, got {samples}, {steps_per_sample}"
        )
    model = NumpyModel(f, theta, upsilon, inertia, potential)
    n = model.n
    xa, pa = check_points(x0, pi0, n, batched=True)
    X = np.ascontiguousarray(np.atleast_2d(xa).reshape(-1, n).T)
    P = np.ascontiguousarray(np.atleast_2d(pa).reshape(-1, n).T)
    _check_start(model, P)
    meth = METHODS[method_name] if method_name else _default_method(model)
    if meth.adaptive:  # steps from the tolerance, per trajectory; steps_per_sample is not used
        if tol is None:
            raise ValueError(
                f"method {meth.name} is adaptive: give tol (a tolerance), not a step count"
            )
        ok, why = meth.applies(model)
        if not ok:
            raise ValueError(f"method {meth.name} does not apply: {why}")
        full = system == "full"
        times = np.linspace(0, tv, samples)
        res = compiled_taylor_samples(
            model, X, P, times, check_tolerance(tol), full=full, progress=progress
        )
        xs = g = None
        if full:
            q = res["quat"]  # (T, 4, N)
            xs = np.stack([quat_to_x(q[k]).T for k in range(samples)])
            g = np.stack([quat_matrix(q[k]) for k in range(samples)])
        return {
            "times": times,
            "pi": np.transpose(res["pi"], (0, 2, 1)).copy(),
            "method": meth,
            "path": res["path"],
            "Gamma": None if res["Gamma"] is None else np.transpose(res["Gamma"], (0, 2, 1)).copy(),
            "x": xs,
            "g": g,
            "error_estimate": res["error_estimate"],
        }
    nsteps = (samples - 1) * steps_per_sample
    rec = {"pi": [], "Gamma": [], "x": []}

    def observe(k, pi, G, x):
        if k % steps_per_sample == 0:
            rec["pi"].append(pi.T.copy())
            if G is not None:
                rec["Gamma"].append(G.T.copy())
            if x is not None:
                rec["x"].append(np.asarray(x).T.copy())
            if progress is not None:
                progress(k // steps_per_sample, samples - 1)

    G0 = None
    if model.gravity:
        adx = np.einsum("aN,mab->Nmb", X, model.f)
        G0 = np.einsum("Nmb,m->bN", _fast._expm_batch(adx, su2=model.su2), model.gamma).T
    observe(0, P, None if G0 is None else G0.T, X if system == "full" else None)
    integrate_fast(model, meth, X, P, tv, nsteps, system=system, observe=observe)
    xs = np.stack(rec["x"]) if rec["x"] else None
    g = None
    if xs is not None:
        T_, N_ = xs.shape[:2]
        g = _group_of(model, xs.reshape(-1, n).T)
        g = g.reshape((T_, N_) + g.shape[1:])
    return {
        "times": np.linspace(0, tv, samples),
        "pi": np.stack(rec["pi"]),
        "method": meth,
        "path": "numpy",
        "Gamma": np.stack(rec["Gamma"]) if rec["Gamma"] else None,
        "x": xs,
        "g": g,
    }
