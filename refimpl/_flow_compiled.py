"""Flows by the compiled adaptive Taylor method (Upsilon = 0): body systems and the su(2) full state.

Systems
    ``body``: ``(pi)`` or ``(pi, Gamma)`` -- the quadratic field of :func:`refimpl._taylor.quadratic_field`
    (Euler twee14/drie6, Euler-Poisson twee17 sign-corrected/twee18, Theta terms).
    ``full`` (su(2)/so(3)): ``(pi, [Gamma,] q)`` with the group element as the unit quaternion ``q``
    (:func:`refimpl._taylor.quadratic_field_su2_full`, ``dq/dt = q * (0, Omega/2)``), still quadratic, so
    the configuration is integrated by the same Taylor recurrences without any chart or re-basing;
    the output ``x`` is the principal logarithm ``x = 2 atan2(|q|, q_0) q/|q|`` (as the splitting
    methods' :func:`refimpl._flow_fast.quat_to_x`), equal to the chart coordinate of the re-basing
    methods wherever that never left ``||ad_x||_F <= 1``.

Error control (per trajectory, never shared)
    The kernel's Jorba-Zou control bounds the *local* remainder by ``eps * max(1, ||y||)`` per step. A
    global tolerance ``tol`` (max-norm over ``pi`` and ``Ad(g)``, the absolute error of what the user
    gets) is met by two runs: ``A`` at ``eps = tol / 100`` and ``B`` at ``eps / 100``; ``|A - B|``
    estimates the error of ``A`` (``B`` is about a hundred times more accurate: the local remainders,
    hence the global error of the method, scale with ``eps``), and ``B`` is returned when
    ``|A - B| <= tol`` on that trajectory. A trajectory over the bound is run again with ``eps`` lowered by the observed excess
    (times 10), until it passes or ``eps`` reaches the float64 floor (then ``ValueError`` names it).
"""

from __future__ import annotations

import numpy as np

from . import _compiled_taylor as _ct
from . import _fast_kernels as _fast
from ._taylor import quadratic_field, quadratic_field_su2_full

__all__ = [
    "PATH",
    "compiled_taylor_body",
    "compiled_taylor_flow",
    "quat_rotation",
    "quat_to_x",
    "supports_full",
    "x_to_quat",
]

EPS = np.finfo(float).eps
PATH = _ct.PATH
_FIELDS: dict = {}
SAFETY = 1e-2  # B's local tolerance relative to A's
EPS_FLOOR = 1e-14  # the floor of A's local tolerance (B's is 1e-16, the Jorba-Zou order 20)
FIRST = 1e-2  # A's first local tolerance relative to the global one (global/local error ~ 10-100
# over 10^2-10^3 steps, so one pair of runs usually suffices)


def _field(model, full: bool) -> _ct.CompiledField:
    key = (
        full,
        model.f.tobytes(),
        model.theta.tobytes(),
        model.Iinv.tobytes(),
        None if not model.gravity else model.Lvec.tobytes(),
    )
    if key not in _FIELDS:
        F = quadratic_field_su2_full(model) if full else quadratic_field(model)
        _FIELDS[key] = _ct.compiled_field(F)
    return _FIELDS[key]


def supports_full(model) -> bool:
    """The compiled full-state Taylor flow covers su(2)/so(3) with ``Upsilon = 0``."""
    return bool(model.upsilon_zero and model.su2)


def quat_to_x(q):
    """``x`` with ``exp(x^a E_a) = q0 - i qv.sigma``: ``x = 2 atan2(|qv|, q0) qv/|qv|`` (|x| <= 2 pi)."""
    s = np.sqrt(np.sum(q[1:] ** 2, axis=0))
    ang = 2 * np.arctan2(s, q[0])
    with np.errstate(invalid="ignore", divide="ignore"):
        fac = np.where(s > 0, ang / np.where(s > 0, s, 1), 2.0)
    return q[1:] * fac


def x_to_quat(x):
    """The unit quaternion ``(cos(|x|/2), sin(|x|/2) x/|x|)`` of ``exp(x^a E_a)``, x of shape (3, N)."""
    t = np.sqrt(np.sum(x**2, axis=0))
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(t > 0, np.sin(t / 2) / np.where(t > 0, t, 1), 0.5)
    return np.concatenate([np.cos(t / 2)[None], s * x])


def quat_rotation(q) -> np.ndarray:
    """``Ad(g)`` (N, 3, 3) of ``g = q_0 - i q.sigma`` (q of shape (4, N), unit): the rotation
    ``(q_0^2 - |q|^2) 1 + 2 q q^T + 2 q_0 [q]_x`` (= ``exp(ad_x)`` for ``q = (cos |x|/2, sin |x|/2 x/|x|)``)."""
    w, v = q[0], q[1:]
    R = np.einsum("aN,bN->Nab", 2 * v, v)
    R += (w * w - np.sum(v * v, axis=0))[:, None, None] * np.eye(3)[None]
    R[:, 0, 1] -= 2 * w * v[2]
    R[:, 1, 0] += 2 * w * v[2]
    R[:, 0, 2] += 2 * w * v[1]
    R[:, 2, 0] -= 2 * w * v[1]
    R[:, 1, 2] -= 2 * w * v[0]
    R[:, 2, 1] += 2 * w * v[0]
    return R


def _gamma0(model, x0):
    if not model.gravity:
        return None
    adx0 = np.einsum("aN,mab->Nmb", x0, model.f)
    Ad0 = _fast._expm_batch(adx0, su2=model.su2)
    return np.einsum("Nmb,m->bN", Ad0, model.gamma)


def compiled_taylor_body(
    model,
    x0,
    pi0,
    t: float,
    *,
    tol: float | None = None,
    order: int | None = None,
    nsteps: int | None = None,
) -> dict:
    """Body system of ``N`` trajectories (``x0``, ``pi0`` of shape (n, N)) to time ``t``: fixed steps
    (``order`` and ``nsteps``) or the adaptive kernel at the *local* tolerance ``tol``.

    Returns the dict of :func:`refimpl._flow_fast.integrate_fast` (``x`` None) plus ``steps`` (N,)."""
    if not model.upsilon_zero:
        raise ValueError(
            "compiled Taylor: the body field is a quadratic polynomial only for Upsilon = 0 (vier6)"
        )
    n, N = pi0.shape
    G0 = _gamma0(model, x0)
    y0 = (pi0 if G0 is None else np.concatenate([pi0, G0])).T
    cf = _field(model, False)
    if nsteps is not None:
        y = _ct.taylor_fixed(cf, y0, t / nsteps, int(nsteps), int(order))
        steps = np.full(N, int(nsteps))
    else:
        y, steps = _ct.taylor_adaptive(cf, y0, t, float(tol), order)
    y = y.T
    return {
        "pi": y[:n],
        "Gamma": None if G0 is None else y[n:],
        "x": None,
        "Ad": None,
        "quat": None,
        "rebases": np.zeros(N, dtype=int),
        "steps": steps,
    }


def _full_run(model, y0, t, eps):
    cf = _field(model, True)
    y, steps = _ct.taylor_adaptive(cf, y0, t, eps)
    return y.T, steps


def compiled_taylor_flow(model, x0, pi0, t: float, tol: float) -> dict:
    """Full state ``(x, pi)`` of ``N`` su(2) trajectories at time ``t`` with the global tolerance ``tol``
    (max-norm over ``pi`` and ``Ad(g)`` per trajectory; the two-run control of the module docstring).

    Returns ``pi``, ``Gamma``, ``x``, ``quat`` (``Ad(g) = quat_rotation(quat)``), ``Ad`` (None), ``rebases`` (zeros: no chart is used), ``steps``
    (of the returned run), ``error_estimate`` (``|A - B|`` per trajectory, an upper estimate of the
    returned run's error) and ``path`` (``numba`` or ``python``)."""
    if not supports_full(model):
        raise ValueError("compiled Taylor full state: written for su(2)/so(3) with Upsilon = 0")
    n, N = pi0.shape
    G0 = _gamma0(model, x0)
    q0 = x_to_quat(x0)
    y0 = np.concatenate([pi0] + ([] if G0 is None else [G0]) + [q0]).T
    eps = np.full(N, min(max(FIRST * tol, EPS_FLOOR), 1e-3))
    todo = np.arange(N)
    res = np.empty((y0.shape[1], N))
    est = np.empty(N)
    steps = np.empty(N, dtype=np.int64)
    for _ in range(8):
        # one tolerance per call: group the trajectories still to do by their eps
        for e in np.unique(eps[todo]):
            idx = todo[eps[todo] == e]
            A, _ = _full_run(model, y0[idx], t, e)
            B, sB = _full_run(model, y0[idx], t, e * SAFETY)
            bad = (sB < 0) | np.any(~np.isfinite(B), axis=0)
            if np.any(bad):
                raise ValueError(
                    f"compiled Taylor flow: trajectories {idx[bad][:10].tolist()} became non-finite before t = {t} "
                    "(diverged); no point is dropped"
                )
            dpi = np.max(np.abs(A[:n] - B[:n]), axis=0)
            # every entry of Ad(g) = R(q) is a quadratic form q^T M q with ||M||_2 = 1 (unit quaternions), so
            # |R(q)_ij - R(q')_ij| = |(q - q')^T M (q + q')| <= 2 ||q - q'||_2: a bound, no rotation formed
            dAd = 2.0 * np.sqrt(np.sum((A[-4:] - B[-4:]) ** 2, axis=0))
            d = np.maximum(dpi, dAd)
            d = np.where(np.isfinite(d), d, np.inf)
            res[:, idx] = B
            est[idx] = d
            steps[idx] = sB
        over = todo[est[todo] > tol]
        if over.size == 0:
            break
        shrink = np.minimum(tol / np.maximum(est[over], tol) / 10, 0.1)
        new = np.maximum(eps[over] * shrink, EPS_FLOOR)
        if np.all(new >= eps[over]):
            break
        eps[over] = new
        todo = over
    over = np.flatnonzero(est > tol)
    if over.size:
        raise ValueError(
            f"compiled Taylor flow: tolerance {tol} not reached on trajectories {over[:10].tolist()} "
            f"(estimated errors {est[over][:3].tolist()}) at the float64 floor of the local tolerance"
        )
    q = res[-4:]
    return {
        "pi": res[:n],
        "Gamma": None if G0 is None else res[n : 2 * n],
        "quat": q,
        "x": quat_to_x(q),
        "Ad": None,
        "rebases": np.zeros(N, dtype=int),
        "steps": steps,
        "error_estimate": est,
        "path": PATH,
    }
