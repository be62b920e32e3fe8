"""Kernels of the fast implementation (float64, batched); the mathematics and the error model are
stated in :mod:`refimpl.fast`, the public face built on these kernels."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import sympy

from . import _compiled_tensors as _ctens
from ._errors import ChartError, DegeneratePointError
from ._phi import phi1, ps_poly
from ._validate import (
    MAX_ELEMENTS,
    check_batch_memory,
    check_inertia,
    check_out_buffer,
    check_points,
    check_potential,
    check_structure_constants,
    check_theta,
    check_upsilon,
    outside_chart,
    refuse_overflow,
    within_boundary,
)
from ._version import __version__

__all__ = ["FastCore", "PoissonBatch", "FieldBatch", "DegeneratePointError", "C_P"]

EPS = np.finfo(float).eps
C_P = 16.0  # constant of the error model, see the module docstring
CHUNK = 16384  # points per chunk of the su(2) kernel (arrays of 128 KiB stay in cache)
TWO_PI = 2 * np.pi


@dataclass(frozen=True)
class PoissonBatch:
    """Poisson tensors of a batch and their per-point diagnostics (see the module docstring).

    ``P`` has shape ``(..., 2n, 2n)`` for ``layout="points"`` and
    ``(2n, 2n, ...)`` for ``layout="components"``.
    """

    P: np.ndarray
    cond_phi: np.ndarray
    cond_data: np.ndarray
    error_bound: np.ndarray
    degenerate: np.ndarray
    path: str
    outside_chart: np.ndarray | None = (
        None  # points at or past the chart edge: NaN, bound inf (issue 15)
    )


@dataclass(frozen=True)
class FieldBatch:
    xdot: np.ndarray
    pidot: np.ndarray
    cond_phi: np.ndarray
    cond_data: np.ndarray
    error_bound: np.ndarray
    degenerate: np.ndarray
    path: str
    outside_chart: np.ndarray | None = (
        None  # points at or past the chart edge: NaN, bound inf (issue 15)
    )


def _chart_hook(f, xa_pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Issue 15 hook: the mask of points outside the chart (``refimpl._validate.outside_chart``) and
    ``x`` with those points replaced by 0, so that they cost nothing; the caller's array is kept."""
    n = f.shape[0]
    out = outside_chart(f, xa_pts.reshape(-1, n)).reshape(xa_pts.shape[:-1])
    if out.any():
        xa_pts = np.where(out[..., None], 0.0, xa_pts)
    return out, xa_pts


def _mark_outside(res, out: np.ndarray, arrays: tuple, points_first: bool):
    """Issue 15 hook: NaN and infinite bounds at the points outside the chart; the flag set."""
    if out.any():
        for a in arrays:
            if points_first:
                a[out] = np.nan
            else:
                a[..., out] = np.nan
        res.error_bound[out] = np.inf
    return res


# ------------------------------------------------------------ model analysis
@lru_cache(maxsize=1)
def _eps3() -> np.ndarray:
    e = np.zeros((3, 3, 3))
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        e[a, b, c] = 1.0
        e[a, c, b] = -1.0
    return e


def _is_su2(f: np.ndarray) -> bool:
    return f.shape == (3, 3, 3) and bool(np.array_equal(f, _eps3()))


@lru_cache(maxsize=8)
def _bernoulli_even(k_max: int) -> np.ndarray:
    """``b_k = B_2k / (2k)!`` for ``k = 1..k_max`` (exact rationals rounded once)."""

    return np.array(
        [float(sympy.bernoulli(2 * k) / sympy.factorial(2 * k)) for k in range(1, k_max + 1)]
    )


def _series_terms(r: float) -> int:
    """Smallest K with ``3.3 r^(2K+2) / (1 - r^2) <= eps/8`` (tail of the B series)."""
    if r <= 0:
        return 1
    target = EPS / 8 * (1 - r * r) / 3.3
    return max(1, int(np.ceil((np.log(target) / np.log(r) - 2) / 2)))


# ------------------------------------------------------------- su(2) kernel
def _su2_frame_coeffs(t2: np.ndarray, need_k: bool = True):
    """``c(t)``, ``lam = (t/2)/sin(t/2)`` (so det L = lam^2) and ``k = lam^2 (t - sin t)/t^3``.

    ``k = (t - sin t) / (2 t (1 - cos t))`` is the coefficient that P_xx needs.
    One transcendental per point: with ``h = t/2`` and ``u = tan(h/2)``,
    ``sin h = 2u/(1+u^2)``, ``cos h = (1-u^2)/(1+u^2)``, hence
    ``h cot h = r (1 - u^2)`` and ``lam = r (1 + u^2)`` with ``r = h/(2u)``, and
    ``k = (t (1+u^2)^2 - 4u(1-u^2)) / (16 t u^2)``.
    """
    t = np.sqrt(t2)
    # Below t = 1/4 the closed forms lose ~1/t^2 digits to cancellation; the
    # series' first omitted term there is < 1e-18 relative.
    small = t < 0.25
    ts = np.where(small, 1.0, t)
    h = 0.5 * ts
    u = np.tan(0.5 * h)
    u2 = u * u
    r = h / (u + u)
    om = 1.0 - u2
    v = 1.0 + u2
    c = 1.0 - r * om
    tts = ts * ts
    c /= tts
    lam = r * v
    k = None
    if need_k:
        k = ts * v * v
        k -= 4.0 * u * om
        k /= 16.0 * ts * u2
    if small.any():
        w = t2[small]
        # Taylor series at t = 0 in w = t^2 (sympy's exact coefficients; the
        # first omitted term is below 1e-18 for t < 1/4):
        c[small] = 1 / 12 + w * (
            1 / 720
            + w * (1 / 30240 + w * (1 / 1209600 + w * (1 / 47900160 + w * (691 / 1307674368000))))
        )
        # lam^2 = ((t/2)/sin(t/2))^2
        lam[small] = np.sqrt(
            1 + w * (1 / 12 + w * (1 / 240 + w * (1 / 6048 + w * (1 / 172800 + w * (1 / 5322240)))))
        )
        if need_k:
            # (t - sin t) / (2 t (1 - cos t))
            k[small] = 1 / 6 + w * (
                1 / 180
                + w * (1 / 5040 + w * (1 / 151200 + w * (1 / 4790016 + w * (691 / 108972864000))))
            )
    return c, lam, k, t


def _write_hat(dst, v) -> None:
    """``dst[:3, :3] = [v]_x`` (``[v]_x w = v x w``) for components-first ``v`` of shape ``(3, N)``."""
    dst[0, 0] = dst[1, 1] = dst[2, 2] = 0.0
    np.negative(v[2], out=dst[0, 1])
    np.copyto(dst[0, 2], v[1])
    np.negative(v[0], out=dst[1, 2])
    np.copyto(dst[1, 0], v[2])
    np.negative(v[1], out=dst[2, 0])
    np.copyto(dst[2, 1], v[0])


def _su2_poisson_chunk(x, p, xi, tau, out, cond, sens, bound, degen):
    """One chunk of the su(2) closed form. ``x``, ``p``: (3, m); ``out``: (6, 6, m)."""
    x0, x1, x2 = x[0], x[1], x[2]
    qv = p + xi[:, None] if xi is not None else p
    q0, q1, q2 = qv[0], qv[1], qv[2]
    t2 = x0 * x0
    t2 += x1 * x1
    t2 += x2 * x2
    c, lam, k, t = _su2_frame_coeffs(t2, need_k=tau is not None)
    # L = d 1 + [x]_x / 2 + c x x^T (d = 1 - c t^2 = (t/2) cot(t/2)), written straight into
    # the P_xp block; with Upsilon it is scaled by 1/C1 on the way.
    d = 1.0 - c * t2
    if tau is not None:
        tv = np.asarray(tau, dtype=float)
        qt = tv @ qv  # q.tau
        c1 = 1.0 - qt
        ic = 1.0 / c1
        dd, cc, hh = d * ic, c * ic, 0.5 * ic
    else:
        dd, cc, hh = d, c, 0.5
    cx0, cx1, cx2 = cc * x0, cc * x1, cc * x2
    hx0, hx1, hx2 = hh * x0, hh * x1, hh * x2
    s01, s02, s12 = cx0 * x1, cx0 * x2, cx1 * x2
    np.multiply(cx0, x0, out=out[0, 3])
    out[0, 3] += dd
    np.multiply(cx1, x1, out=out[1, 4])
    out[1, 4] += dd
    np.multiply(cx2, x2, out=out[2, 5])
    out[2, 5] += dd
    np.subtract(s01, hx2, out=out[0, 4])
    np.add(s01, hx2, out=out[1, 3])
    np.add(s02, hx1, out=out[0, 5])
    np.subtract(s02, hx1, out=out[2, 3])
    np.subtract(s12, hx0, out=out[1, 5])
    np.add(s12, hx0, out=out[2, 4])
    # frame condition: grows as |x| -> 2 pi (chart boundary); lam >= 1
    frame = t * (-1.0 / TWO_PI)
    frame += 1.0
    np.maximum(frame, EPS, out=frame)
    if tau is None:
        for i in range(3):
            for j in range(3):
                np.negative(out[i, 3 + j], out=out[3 + j, i])
        out[:3, :3] = 0.0
        out[3, 3] = out[4, 4] = out[5, 5] = 0.0
        np.negative(q2, out=out[3, 4])
        np.copyto(out[3, 5], q1)
        np.negative(q0, out=out[4, 5])
        np.copyto(out[4, 3], q2)
        np.negative(q1, out=out[5, 3])
        np.copyto(out[5, 4], q0)
        cond[...] = 1.0
        sens[...] = 1.0
        # |P| <= max(||L||_max <= lam^2, |q|_max): bound = 3 C_P eps max(lam^2, |q|, 1) / frame
        qa = np.abs(q0)
        np.maximum(qa, np.abs(q1), out=qa)
        np.maximum(qa, np.abs(q2), out=qa)
        lam *= lam
        np.maximum(lam, qa, out=lam)
        lam *= C_P * 3 * EPS
        np.divide(lam, frame, out=bound)
        degen[...] = False
        return
    # ---- Upsilon = tau.eps: Phi = C1 + tau q^T, Psi^-1 = (1 - q tau^T)/C1 (section cinq)
    aic = np.abs(ic)
    Lb = out[:3, 3:]  # (3, 3, m) view holding L / C1
    lq = Lb[:, 0] * q0  # (L q) / C1
    lq += Lb[:, 1] * q1
    lq += Lb[:, 2] * q2
    # P_xp = (L - (L q) tau^T) / C1 ; P_px = -P_xp^T
    Lb -= lq[:, None, :] * tv[None, :, None]
    np.negative(Lb.transpose(1, 0, 2), out=out[3:, :3])
    # P_pp = [q]_x / C1
    qi = qv * ic
    _write_hat(out[3:, 3:], qi)
    # P_xx = det(L) [phi1(K) tau]_x / C1 with phi1(K) tau = tau + a1 x*tau + a2 x*(x*tau),
    # a1 = 1/(2 lam^2), a2 = (t - sin t)/t^3. With det L = lam^2:
    #   det(L) phi1(K) tau = d tau + k (x.tau) x + (x*tau)/2,
    # since lam^2 (1 - a2 t^2) = lam^2 sin t / t = (t/2) cot(t/2) = d and k = lam^2 a2.
    xv = x
    cross = np.array(
        [[0.0, tv[2], -tv[1]], [-tv[2], 0.0, tv[0]], [tv[1], -tv[0], 0.0]]
    )  # cross @ x = x * tau
    w = (0.5 * cross) @ xv
    k *= tv @ xv
    w += k * xv
    w += d * tv[:, None]
    w *= ic
    _write_hat(out[:3, :3], w)
    # cond_F(Phi)/3 with Phi = C1 + tau q^T: ||Phi||_F^2 = C1 (3 C1 + 2 q.tau) + |tau|^2 |q|^2,
    # ||Phi^-1||_F^2 = (3 - 2 q.tau + |tau|^2 |q|^2) / C1^2.
    tn2 = float(tv @ tv)
    tn = np.sqrt(tn2)
    qn2 = np.einsum("im,im->m", qv, qv)
    tq = qn2 * tn2
    nf2 = 3.0 * c1
    nf2 += 2.0 * qt
    nf2 *= c1
    nf2 += tq
    ni2 = tq - 2.0 * qt
    ni2 += 3.0
    np.sqrt(nf2 * ni2, out=cond)
    cond *= aic
    cond *= 1.0 / 3.0
    # cond_data = ||Phi^-1||_F (1 + ||S||_F ||U||_F)/sqrt(3), ||[v]_x||_F = sqrt(2)|v|.
    # It dominates cond_phi here (||Phi||_F <= sqrt(3)|C1| + |tau||q| and |C1| <= 1 + |tau||q|),
    # so it alone enters the bound.
    qn = np.sqrt(qn2)
    np.sqrt(ni2, out=sens)
    g = qn * (2.0 * tn)
    g += 1.0
    g *= aic * (1.0 / np.sqrt(3.0))
    sens *= g
    # |P| <= (lam^2 (1 + |tau| lam) + lam (1 + |q||tau|) + |q|) / |C1|  (blockwise norms)
    sc = lam * tn
    sc += 1.0
    sc *= lam * lam
    sc += lam * (1 + qn * tn)
    sc += qn
    sc *= aic
    np.maximum(sc, 1.0, out=sc)
    sc *= sens
    sc /= frame
    np.multiply(sc, C_P * 3 * EPS, out=bound)
    bad = ~(sens < 1.0 / (3 * C_P * EPS))
    bad |= c1 == 0
    np.copyto(degen, bad)
    if bad.any():
        out[:, :, bad] = np.nan
        bound[bad] = np.inf
        cond[bad] = np.inf
        sens[bad] = np.inf


def _su2_theta_to_xi(theta: np.ndarray | None) -> np.ndarray | None:
    """Theta_ab = -xi_k eps_kab  =>  xi_0 = -Theta_12, xi_1 = -Theta_20, xi_2 = -Theta_01."""
    if theta is None:
        return None
    return np.array([-theta[1, 2], -theta[2, 0], -theta[0, 1]])


def _su2_upsilon_to_tau(u: np.ndarray | None):
    """Upsilon^mn = tau_l eps_lmn  =>  tau_0 = U_12, tau_1 = U_20, tau_2 = U_01."""
    if u is None:
        return None
    return (float(u[1, 2]), float(u[2, 0]), float(u[0, 1]))


# ------------------------------------------------------------ generic kernel
def _frame_series(A: np.ndarray, r: float) -> np.ndarray:
    """``L = B(A)`` by the even Bernoulli series; ``r`` bounds ``||A||_2 / 2 pi`` over the batch."""
    n = A.shape[-1]
    eye = np.eye(n)
    K = _series_terms(r)
    coeffs = np.concatenate([[1.0], _bernoulli_even(K)])
    return ps_poly(A @ A, coeffs, eye) + 0.5 * A


SERIES_BINS = (0.25, 0.45, 0.7)  # bins of r = ||ad_x||_2 / 2pi summed by the Bernoulli series


def _frames_generic(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``L(g, e)`` for a batch of ``ad_x`` (N, n, n), and ``r >= ||ad_x||_2 / 2 pi`` per point.

    ``||A||_2 <= min(||A||_F, sqrt(||A||_1 ||A||_inf))``. Points with ``r < 0.7`` use the
    Bernoulli series, grouped in bins of ``r`` so each bin sums only the terms it
    needs; the rest use scaling and squaring of phi1 and an inverse.
    """
    fro = np.sqrt(np.sum(A * A, axis=(-2, -1)))
    n1 = np.max(np.sum(np.abs(A), axis=-2), axis=-1)
    ninf = np.max(np.sum(np.abs(A), axis=-1), axis=-1)
    r = np.minimum(fro, np.sqrt(n1 * ninf)) / TWO_PI
    L = np.empty_like(A)
    lo = -1.0
    for hi in SERIES_BINS:
        sel = (r > lo) & (r <= hi)
        if sel.any():
            L[sel] = _frame_series(A[sel], float(r[sel].max()))
        lo = hi
    rest = r > SERIES_BINS[-1]
    if rest.any():
        phi = phi1(-A[rest])
        L[rest] = _inv_batch(phi)
    return L, r


def _inv_batch(M: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.inv(M)
    except np.linalg.LinAlgError:
        out = np.empty_like(M)
        for k in range(M.shape[0]):
            try:
                out[k] = np.linalg.inv(M[k])
            except np.linalg.LinAlgError:
                out[k] = np.nan
        return out


def _frob(M: np.ndarray) -> np.ndarray:
    with np.errstate(
        over="ignore", invalid="ignore"
    ):  # inf for entries near 1e300: a bound, not an error
        return np.sqrt(np.sum(M * M, axis=(-2, -1)))


def _summand_norms(f, theta, x, p):
    """``||sum_m |pi_m| |f^m| + |Theta| ||_F`` and ``||sum_a |x^a| |f_a| ||_F`` per point.

    Forming ``S = pi.f - Theta`` (vier3) and ``ad_x = x.f`` in float64 rounds each entry by up to
    ``n eps`` times the magnitudes of its summands; under cancellation (an ill-conditioned basis,
    ``LieAlgebra.change_basis``) these exceed ``||S||``, ``||ad_x||`` by any factor.
    """
    N, n = x.shape
    absf = np.abs(f)
    Sabs = (np.abs(p) @ absf.reshape(n, n * n)).reshape(N, n, n)
    if theta is not None:
        Sabs += np.abs(theta)
    Aabs = (np.abs(x) @ absf.transpose(1, 0, 2).reshape(n, n * n)).reshape(N, n, n)
    return _frob(Sabs), _frob(Aabs)


GENERIC_CHUNK = 2048  # points per chunk of the generic path: its (chunk, n, n) stacks stay in cache


def _generic_poisson(f, theta, upsilon, x, p, out=None):
    """Batch-first generic path. ``x``, ``p``: (N, n). Returns P (N, 2n, 2n), cond, sens, bound, degen."""
    N, n = x.shape
    P = np.empty((N, 2 * n, 2 * n)) if out is None else out
    cond, sens, bound, degen = np.empty(N), np.empty(N), np.empty(N), np.empty(N, dtype=bool)
    for s in range(0, N, GENERIC_CHUNK):
        e = min(N, s + GENERIC_CHUNK)
        _generic_poisson_chunk(
            f, theta, upsilon, x[s:e], p[s:e], P[s:e], cond[s:e], sens[s:e], bound[s:e], degen[s:e]
        )
    return P, cond, sens, bound, degen


def _psi_cond_sens(f_psi, f_psi_inv, f_s, n_ups, n: int):
    """The conditioning of the solve by ``Psi = 1 + Upsilon S`` in the error model, from Frobenius norms
    (floats or arrays alike): ``cond = ||Psi|| ||Psi^-1|| / n`` and ``sens = ||Psi^-1|| (1 + ||S||
    ||Upsilon||) / sqrt(n)``; a point is degenerate unless ``max(cond, sens) n C_P eps < 1``
    (:func:`_generic_poisson_chunk`, :func:`_degenerate_at_origin`)."""
    return f_psi * f_psi_inv / n, f_psi_inv * (1 + f_s * n_ups) / math.sqrt(n)


def _generic_poisson_chunk(f, theta, upsilon, x, p, P, cond_out, sens_out, bound_out, degen_out):
    N, n = x.shape
    A = (x @ f.transpose(1, 0, 2).reshape(n, n * n)).reshape(N, n, n)
    L, r = _frames_generic(A)
    S = (p @ f.reshape(n, n * n)).reshape(N, n, n)
    if theta is not None:
        S -= theta
    Sabs, Aabs = _summand_norms(f, theta, x, p)
    if upsilon is None:
        P[:, :n, :n] = 0.0
        P[:, :n, n:] = L
        P[:, n:, :n] = -L.transpose(0, 2, 1)
        P[:, n:, n:] = -S
        cond = np.ones(N)
        sens = np.ones(N)
    else:
        # U @ S_k for every k as one BLAS GEMM on the stacked columns (a broadcast matmul is slow)
        Psi = (upsilon @ S.transpose(1, 0, 2).reshape(n, -1)).reshape(n, N, n).transpose(1, 0, 2)
        Psi += np.eye(n)
        Psi_inv = _inv_batch(Psi)
        with np.errstate(invalid="ignore", over="ignore"):
            cond, sens = _psi_cond_sens(
                _frob(Psi), _frob(Psi_inv), _frob(S), float(np.linalg.norm(upsilon)), n
            )
        sens = np.where(np.isfinite(sens), sens, np.inf)
        Pxp = L @ Psi_inv
        Ppp = -(S @ Psi_inv)
        Pxx = -((Pxp.reshape(-1, n) @ upsilon).reshape(N, n, n) @ L.transpose(0, 2, 1))
        P[:, :n, :n] = 0.5 * (Pxx - Pxx.transpose(0, 2, 1))
        P[:, :n, n:] = Pxp
        P[:, n:, :n] = -Pxp.transpose(0, 2, 1)
        P[:, n:, n:] = 0.5 * (Ppp - Ppp.transpose(0, 2, 1))
    cond = np.where(np.isfinite(cond), cond, np.inf)
    frame = 1.0 / np.maximum(1.0 - np.minimum(r, 1.0), EPS)
    with np.errstate(invalid="ignore", over="ignore"):
        pmax = np.max(np.abs(P), axis=(-2, -1))
        scale = np.maximum(pmax, 1.0)
        eff = np.maximum(cond, sens)
        if upsilon is None:
            data = n * Sabs  # G = [[0], [1]]: P_pp = -S
        else:
            # first order in dS: dP = G dS G^T, G = T (-W^-1)[:, :n] = -[[L U Phi^-1], [Phi^-1]] (vier9)
            Phi_inv = Psi_inv.transpose(0, 2, 1)
            data = Sabs * (_frob(L @ (upsilon @ Phi_inv)) ** 2 + _frob(Phi_inv) ** 2)
        bound = C_P * n * EPS * frame * (eff * scale + data + Aabs * pmax)
    degen = ~(eff * (n * C_P * EPS) < 1.0) | ~np.all(np.isfinite(L), axis=(-2, -1))
    if degen.any():
        P[degen] = np.nan
        bound[degen] = np.inf
        cond[degen] = np.inf
        sens[degen] = np.inf
    cond_out[...] = cond
    sens_out[...] = sens
    bound_out[...] = bound
    degen_out[...] = degen


def _check_points_fast(x, pi, n: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`refimpl._validate.check_points` (batched), with its per-point finiteness pass replaced by
    one sum per array for float64 arrays of the right shapes: a sum is finite only if every entry
    is (NaN and inf propagate, inf - inf is NaN). Otherwise, and whenever a sum is not finite
    (a bad entry, or finite entries whose sum overflows), ``check_points`` itself decides and
    raises its own error naming the input and the points."""
    if (
        isinstance(x, np.ndarray)
        and isinstance(pi, np.ndarray)
        and x.dtype == np.float64
        and pi.dtype == np.float64
        and x.shape == pi.shape
        and x.shape[-1:] == (n,)
        and x.size <= MAX_ELEMENTS
    ):
        if within_boundary(x) and within_boundary(pi):  # issue 30 hook: finite and |v| <= 1e300
            return x, pi
    return check_points(x, pi, n, batched=True)


def start_degenerate(f, theta, upsilon, p) -> np.ndarray:
    """The degenerate flags of the Poisson tensor at ``x = 0`` for the points ``p`` (N, n): the flows'
    start check (:func:`refimpl.flows._fast._check_start`). su(2): its closed form
    (:meth:`FastCore.poisson_batch_validated`); any other algebra :func:`_degenerate_at_origin`, which
    compiles nothing (the generic kernel costs ~4 s per dimension on a cold cache, issue 25). The
    one-trajectory runners of ``Upsilon != 0`` check one point by the same rules compiled
    (:func:`refimpl._full_state_rational.start_check`; tests/test_full_state_rational.py checks that
    both flag the same points) and refuse through this one."""
    if _is_su2(f):
        return FastCore().poisson_batch_validated(f, theta, upsilon, np.zeros_like(p), p).degenerate
    return _degenerate_at_origin(f, theta, upsilon, p)


def _degenerate_at_origin(f, theta, upsilon, p) -> np.ndarray:
    """The ``degen`` flags of :func:`_generic_poisson` (and of the compiled generic kernel) at ``x = 0``
    for the points ``p`` (N, n), computing only them: there the frame is ``L = 1`` exactly (``ad_x =
    0``), so the flag is the solve's conditioning alone (:func:`_psi_cond_sens`, with ``S_aj = pi_i
    f^i_aj - Theta_aj``); an exactly singular or non-finite ``Psi`` is degenerate. ``upsilon`` None:
    ``Psi = 1``, no point is. One point (a protocol call) by 2-d operations and floats."""
    p = np.asarray(p, dtype=float)
    N, n = p.shape
    if upsilon is None:
        return np.zeros(N, dtype=bool)
    ups = np.asarray(upsilon, dtype=float)
    S = (p @ np.asarray(f, dtype=float).reshape(n, n * n)).reshape(N, n, n)
    if theta is not None:
        S -= np.asarray(theta, dtype=float)
    Psi = ups @ S
    Psi.reshape(N, n * n)[:, :: n + 1] += 1.0
    c = n * C_P * EPS  # degenerate unless max(cond, sens) c < 1 (NaN: degenerate)
    n_ups = math.sqrt(np.vdot(ups, ups))
    with np.errstate(all="ignore"):
        if N == 1:
            try:
                Pi = np.linalg.inv(Psi[0])
            except np.linalg.LinAlgError:  # exactly singular
                return np.ones(1, dtype=bool)
            cond, sens = _psi_cond_sens(
                math.sqrt(np.vdot(Psi, Psi)),
                math.sqrt(np.vdot(Pi, Pi)),
                math.sqrt(np.vdot(S, S)),
                n_ups,
                n,
            )
            return np.array([not (cond * c < 1.0 and sens * c < 1.0)])
        Pi = _inv_batch(Psi)
        cond, sens = _psi_cond_sens(_frob(Psi), _frob(Pi), _frob(S), n_ups, n)
        return ~((cond * c < 1.0) & (sens * c < 1.0))


# ------------------------------------------------ constants of the compiled kernels
def _ct_consts() -> dict:
    """The error model's constants, written into the compiled kernels' source (refimpl._compiled_tensors)."""
    return {"EPS": EPS, "C_P": C_P, "TWO_PI": TWO_PI, "SERIES_MAX": SERIES_BINS[-1]}


@lru_cache(maxsize=1)
def _ct_bernoulli() -> np.ndarray:
    """``1, b_1, ..., b_K`` with K the number of series terms at ``r = SERIES_BINS[-1]``."""
    return np.concatenate([[1.0], _bernoulli_even(_series_terms(SERIES_BINS[-1]))])


# ----------------------------------------------------------------- the class
class FastCore:
    """The fast float64 implementation (protocol methods ``poisson_tensor``, ``hamiltonian_vector_field``).

    Protocol contract (docs/design.md): ``batched = True``; outputs carry the
    leading axes of ``x`` and ``pi``; a degenerate point raises
    :class:`DegeneratePointError` naming the points. The richer batch API,
    :meth:`poisson_batch` and :meth:`vector_field_batch`, never raises for
    degenerate points: it flags them and returns NaN there.
    """

    name = "tstarg-fast"
    version = __version__  # the package's (pyproject.toml)
    batched = True
    precision_digits = 15.9  # float64

    # -------------------------------------------------------- preparation
    @staticmethod
    def _model(f, theta, upsilon):
        f = check_structure_constants(f)
        n = f.shape[0]
        th = check_theta(theta, f)
        up = check_upsilon(upsilon, n)
        return f, (None if not th.any() else th), (None if not up.any() else up)

    def poisson_batch(
        self,
        f,
        theta,
        upsilon,
        x,
        pi,
        *,
        layout: str = "points",
        out: np.ndarray | None = None,
        compiled: bool | None = None,
    ) -> PoissonBatch:
        """Poisson tensors of a batch with ``cond_phi``, ``error_bound`` and ``degenerate`` per point.

        ``layout="points"``: ``x``, ``pi`` of shape ``(..., n)``, ``P`` of shape
        ``(..., 2n, 2n)``. ``layout="components"``: ``x``, ``pi`` of shape
        ``(n, ...)`` and ``P`` of shape ``(2n, 2n, ...)`` -- the su(2) fast
        path's native layout, with no transposes.

        ``out``: an optional float64 C-contiguous array of ``P``'s shape to
        write into (repeated calls then reuse memory instead of paying the
        operating system's first-touch cost of a fresh 2n x 2n x N array).

        ``compiled``: ``None`` (default) runs the numba kernels of
        :mod:`refimpl._compiled_tensors` when numba imports, else the numpy kernels; ``True``
        requires numba; ``False`` forces numpy. ``path`` names what ran.
        """
        check_out_buffer(out, ("x", x), ("pi", pi))  # issue 30 hook: read-only or aliasing out=
        f, th, up = self._model(f, theta, upsilon)
        return self.poisson_batch_validated(
            f, th, up, x, pi, layout=layout, out=out, compiled=compiled
        )

    def poisson_batch_validated(
        self, f, th, up, x, pi, *, layout: str = "points", out=None, compiled: bool | None = None
    ) -> PoissonBatch:
        """:meth:`poisson_batch` on a model already validated (the arrays of a
        :class:`refimpl.model.Model`): the structure constants, Theta and Upsilon are not checked
        again; the points are."""
        n = f.shape[0]
        check_batch_memory(np.size(x) // n, n, what="poisson_batch")  # issue 30 hook
        if compiled is None:
            compiled = _ctens.HAVE_NUMBA
        elif compiled and not _ctens.HAVE_NUMBA:
            raise ValueError("compiled=True needs numba, which cannot be imported here")
        if compiled:
            return self._poisson_compiled(f, th, up, x, pi, layout, out)
        if layout == "components":
            xa, pa = np.asarray(x), np.asarray(pi)
            if xa.ndim == 0 or pa.ndim == 0:
                raise ValueError(
                    f"x and pi must have shape (n, ...) for layout='components', got {xa.shape} and {pa.shape}"
                )
            xa_pts, pa_pts = check_points(
                np.moveaxis(xa, 0, -1), np.moveaxis(pa, 0, -1), n, batched=True
            )
            outside, xa_pts = _chart_hook(f, xa_pts)
            xa, pa = np.moveaxis(xa_pts, -1, 0), np.moveaxis(pa_pts, -1, 0)
            batch_shape = xa.shape[1:]
        elif layout == "points":
            xa_pts, pa_pts = check_points(x, pi, n, batched=True)
            outside, xa_pts = _chart_hook(f, xa_pts)
            batch_shape = xa_pts.shape[:-1]
        else:
            raise ValueError(f"layout must be 'points' or 'components', got {layout!r}")
        N = int(np.prod(batch_shape, dtype=int))
        if _is_su2(f):
            xc = (
                np.ascontiguousarray(xa.reshape(3, N))
                if layout == "components"
                else np.ascontiguousarray(xa_pts.reshape(N, 3).T)
            )
            pc = (
                np.ascontiguousarray(pa.reshape(3, N))
                if layout == "components"
                else np.ascontiguousarray(pa_pts.reshape(N, 3).T)
            )
            if layout == "components" and out is not None:
                P = self._check_out(out, (6, 6) + batch_shape).reshape(6, 6, N)
            else:
                P = np.empty((6, 6, N))
            cond, sens, bound, degen = (
                np.empty(N),
                np.empty(N),
                np.empty(N),
                np.empty(N, dtype=bool),
            )
            xi, tau = _su2_theta_to_xi(th), _su2_upsilon_to_tau(up)
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                for s in range(0, N, CHUNK):
                    e = min(N, s + CHUNK)
                    _su2_poisson_chunk(
                        xc[:, s:e],
                        pc[:, s:e],
                        xi,
                        tau,
                        P[:, :, s:e],
                        cond[s:e],
                        sens[s:e],
                        bound[s:e],
                        degen[s:e],
                    )
            if layout == "points":
                Pp = (
                    np.empty((N, 6, 6))
                    if out is None
                    else self._check_out(out, batch_shape + (6, 6)).reshape(N, 6, 6)
                )
                np.copyto(Pp, np.moveaxis(P, -1, 0))
                P = Pp.reshape(batch_shape + (6, 6))
            else:
                P = P.reshape((6, 6) + batch_shape)
            path = (
                "su2-closed-form" + ("" if up is not None else ", Upsilon = 0: no Phi") + "; numpy"
            )
        else:
            buf = None
            if out is not None and layout == "points":
                buf = self._check_out(out, batch_shape + (2 * n, 2 * n)).reshape(N, 2 * n, 2 * n)
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                P, cond, sens, bound, degen = _generic_poisson(
                    f, th, up, xa_pts.reshape(N, n), pa_pts.reshape(N, n), out=buf
                )
            if layout == "points":
                P = P.reshape(batch_shape + (2 * n, 2 * n))
            elif out is not None:
                dst = self._check_out(out, (2 * n, 2 * n) + batch_shape)
                np.copyto(dst.reshape(2 * n, 2 * n, N), np.moveaxis(P, 0, -1))
                P = dst
            else:
                P = np.moveaxis(P, 0, -1).reshape((2 * n, 2 * n) + batch_shape)
            path = "generic" + ("" if up is not None else ", Upsilon = 0: no Phi") + "; numpy"
        return _mark_outside(
            PoissonBatch(
                P=P,
                cond_phi=cond.reshape(batch_shape),
                cond_data=sens.reshape(batch_shape),
                error_bound=bound.reshape(batch_shape),
                degenerate=degen.reshape(batch_shape),
                path=path,
                outside_chart=outside,
            ),
            outside,
            (P,),
            layout == "points",
        )

    def _poisson_compiled(self, f, th, up, x, pi, layout, out) -> PoissonBatch:
        """:meth:`poisson_batch` on the numba kernels, written straight into the requested layout."""
        n = f.shape[0]
        if layout == "components":
            xa, pa = np.asarray(x), np.asarray(pi)
            if xa.ndim == 0 or pa.ndim == 0:
                raise ValueError(
                    f"x and pi must have shape (n, ...) for layout='components', got {xa.shape} and {pa.shape}"
                )
            xa_pts, pa_pts = _check_points_fast(np.moveaxis(xa, 0, -1), np.moveaxis(pa, 0, -1), n)
            batch_shape = xa_pts.shape[:-1]
            N = int(np.prod(batch_shape, dtype=int))
            # (N, n) views of the components-first inputs (a copy only if they are not contiguous)
            xv = np.moveaxis(xa_pts, -1, 0).reshape(n, N).T
            pv = np.moveaxis(pa_pts, -1, 0).reshape(n, N).T
            shape = (2 * n, 2 * n) + batch_shape
            Pfull = np.empty(shape) if out is None else self._check_out(out, shape)
            P = Pfull.reshape(2 * n, 2 * n, N).transpose(2, 0, 1)
        elif layout == "points":
            xa_pts, pa_pts = _check_points_fast(x, pi, n)
            batch_shape = xa_pts.shape[:-1]
            N = int(np.prod(batch_shape, dtype=int))
            xv, pv = xa_pts.reshape(N, n), pa_pts.reshape(N, n)
            shape = batch_shape + (2 * n, 2 * n)
            Pfull = np.empty(shape) if out is None else self._check_out(out, shape)
            P = Pfull.reshape(N, 2 * n, 2 * n)
        else:
            raise ValueError(f"layout must be 'points' or 'components', got {layout!r}")
        cond, sens, bound = np.empty(N), np.empty(N), np.empty(N)
        degen, outside = np.zeros(N, dtype=bool), np.zeros(N, dtype=bool)
        if _is_su2(f):
            _ctens.su2_poisson(
                xv, pv, _su2_theta_to_xi(th), _su2_upsilon_to_tau(up), P, cond, sens, bound, degen,
                outside, consts=_ct_consts(),
            )  # fmt: skip
            path = "su2-closed-form"
        else:
            kw = {"bern": _ct_bernoulli(), "consts": _ct_consts()}
            r = _ctens.generic_poisson(f, th, up, xv, pv, P, cond, sens, bound, degen, **kw)
            # the chart (refimpl._validate.outside_chart) only where the norm bound reaches its edge;
            # those points are recomputed at x = 0, as the numpy path's hook does
            cand = np.flatnonzero(~(r < (1 - 1e-3) * (1 - 1e-6)))
            if cand.size:
                off = cand[outside_chart(f, np.ascontiguousarray(xv[cand]))]
                if off.size:
                    outside[off] = True
                    m = off.size
                    sub = (np.empty((m, 2 * n, 2 * n)), np.empty(m), np.empty(m), np.empty(m))
                    subd = np.zeros(m, dtype=bool)
                    _ctens.generic_poisson(
                        f, th, up, np.zeros((m, n)), np.ascontiguousarray(pv[off]),
                        sub[0], sub[1], sub[2], sub[3], subd, **kw,
                    )  # fmt: skip
                    P[off], cond[off], sens[off], bound[off], degen[off] = *sub, subd
            path = "generic"
        path += ("" if up is not None else ", Upsilon = 0: no Phi") + "; compiled (numba)"
        if outside.any():
            P[outside] = np.nan
            bound[outside] = np.inf
        return PoissonBatch(
            P=Pfull,
            cond_phi=cond.reshape(batch_shape),
            cond_data=sens.reshape(batch_shape),
            error_bound=bound.reshape(batch_shape),
            degenerate=degen.reshape(batch_shape),
            path=path,
            outside_chart=outside.reshape(batch_shape),
        )

    @staticmethod
    def _check_out(out: np.ndarray, shape: tuple) -> np.ndarray:
        if (
            not isinstance(out, np.ndarray)
            or out.dtype != np.float64
            or out.shape != shape
            or not out.flags.c_contiguous
        ):
            raise ValueError(f"out must be a C-contiguous float64 array of shape {shape}")
        return out

    # ------------------------------------------------------ vector field
    def vector_field_batch(self, f, theta, upsilon, inertia, potential, x, pi) -> FieldBatch:
        """``(xdot, pidot)`` of vier10/vier11 for a batch, with per-point diagnostics.

        ``Omega = Psi^-1 (dK - U dV)``, ``pidot = Phi^-1 (-dV - S dK)``,
        ``xdot = L(g, e) Omega``; ``dV_b = -Gamma_m f^m_bc L^c``,
        ``Gamma = exp(ad_x)^T gamma`` (twee16). Degenerate points are NaN
        and flagged.
        """
        f, th, up = self._model(f, theta, upsilon)
        n = f.shape[0]
        check_batch_memory(np.size(x) // n, n, what="vector_field_batch")  # issue 30 hook
        inertia = check_inertia(inertia, n)
        pot = check_potential(potential, n)
        xa, pa = check_points(x, pi, n, batched=True)
        outside, xa = _chart_hook(f, xa)
        batch_shape = xa.shape[:-1]
        N = int(np.prod(batch_shape, dtype=int))
        X, Pm = xa.reshape(N, n), pa.reshape(N, n)
        Iinv = np.linalg.inv(inertia)
        Iinv = 0.5 * (Iinv + Iinv.T)
        dK = Pm @ Iinv
        A = (X @ f.transpose(1, 0, 2).reshape(n, n * n)).reshape(N, n, n)
        if _is_su2(f):
            t2 = np.sum(X * X, axis=1)
            c, lam, _, t = _su2_frame_coeffs(t2, need_k=False)
            K = A
            L = np.eye(n) + 0.5 * K + c[:, None, None] * (K @ K)
            r = t / TWO_PI
        else:
            L, r = _frames_generic(A)
        S = (Pm @ f.reshape(n, n * n)).reshape(N, n, n)
        if th is not None:
            S -= th
        if pot is None:
            dV = None
        else:
            Ad = _expm_batch(A, su2=_is_su2(f))
            Gamma = np.einsum("Nmb,m->Nb", Ad, pot["gamma"])
            dV = -np.einsum("Nm,mbc,c->Nb", Gamma, f, pot["L"])
        v = dK if dV is None else (dK if up is None else dK - dV @ up.T)
        u = -np.einsum("Nab,Nb->Na", S, dK)
        if dV is not None:
            u = u - dV
        if up is None:
            Omega, pidot = v, u
            cond = np.ones(N)
            sens = np.ones(N)
        else:
            Psi = np.eye(n) + up @ S
            Psi_inv = _inv_batch(Psi)
            Omega = np.einsum("Nab,Nb->Na", Psi_inv, v)
            pidot = np.einsum("Nba,Nb->Na", Psi_inv, u)  # Phi^-1 = Psi^-T
            with np.errstate(invalid="ignore", over="ignore"):
                cond = _frob(Psi) * _frob(Psi_inv) / n
                sens = _frob(Psi_inv) * (1 + _frob(S) * np.linalg.norm(up)) / np.sqrt(n)
            cond = np.where(np.isfinite(cond), cond, np.inf)
            sens = np.where(np.isfinite(sens), sens, np.inf)
        xdot = np.einsum("Nab,Nb->Na", L, Omega)
        frame = 1.0 / np.maximum(1.0 - np.minimum(r, 1.0), EPS)
        # rounding in forming dK = I^-1 pi (cond(I)), S and ad_x (summand magnitudes), to first order
        Sabs, Aabs = _summand_norms(f, th, X, Pm)
        kappa_I = float(np.linalg.norm(inertia) * np.linalg.norm(Iinv))
        with np.errstate(invalid="ignore", over="ignore"):
            nd = np.linalg.norm(dK, axis=1)
            if up is None:
                d_pidot = Sabs * nd + _frob(S) * kappa_I * nd
                d_omega = kappa_I * nd
            else:
                pn, un, Sn = _frob(Psi_inv), float(np.linalg.norm(up)), _frob(S)
                d_pidot = pn * (Sabs * nd + Sn * kappa_I * nd) + pn**2 * un * Sabs * (Sn * nd + 1)
                d_omega = pn * kappa_I * nd + pn**2 * un * Sabs * nd
            d_xdot = _frob(L) * d_omega + Aabs * np.linalg.norm(Omega, axis=1)
            extra = C_P * n * EPS * frame * (d_pidot + d_xdot)
        with np.errstate(invalid="ignore", over="ignore"):
            scale = np.maximum(
                np.maximum(np.max(np.abs(xdot), axis=1), np.max(np.abs(pidot), axis=1)), 1.0
            )
            scale = scale * np.maximum(1.0, np.max(np.abs(L), axis=(1, 2)))
            eff = np.maximum(cond, sens)
            bound = C_P * n * EPS * eff * frame * scale + extra
        degen = ~(eff * (n * C_P * EPS) < 1.0)
        if degen.any():
            xdot[degen] = np.nan
            pidot[degen] = np.nan
            bound[degen] = np.inf
        res = FieldBatch(
            xdot=xdot.reshape(batch_shape + (n,)),
            pidot=pidot.reshape(batch_shape + (n,)),
            cond_phi=cond.reshape(batch_shape),
            cond_data=sens.reshape(batch_shape),
            error_bound=bound.reshape(batch_shape),
            degenerate=degen.reshape(batch_shape),
            path="su2" if _is_su2(f) else "generic",
            outside_chart=outside,
        )
        return _mark_outside(res, outside, (res.xdot, res.pidot), True)

    # ---------------------------------------------------------- protocol
    @staticmethod
    def _raise_degenerate(degen: np.ndarray, what: str) -> None:
        if np.any(degen):
            idx = [tuple(int(i) for i in b) for b in np.argwhere(degen)]
            shown = ", ".join(str(i) for i in idx[:10]) + (
                f" and {len(idx) - 10} more" if len(idx) > 10 else ""
            )
            raise DegeneratePointError(
                f"{what}: {len(idx)} point(s) on the degenerate set Pi_1 (Delta = det Phi = 0 to float64 "
                f"accuracy, vier12): batch indices {shown}"
            )

    @staticmethod
    def _raise_outside(out, what: str) -> None:
        if out is not None and np.any(out):
            idx = [tuple(int(i) for i in b) for b in np.argwhere(out)]
            shown = ", ".join(str(i) for i in idx[:10]) + (
                f" and {len(idx) - 10} more" if len(idx) > 10 else ""
            )
            raise ChartError(
                f"{what}: {len(idx)} point(s) x outside the chart of exponential coordinates (max |Im eigenvalue "
                f"of ad_x| >= 2 pi, twee1; su(2): |x| >= 2 pi): {'batch indices ' + shown if shown != '()' else 'the point given'}"
            )

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        """Protocol method 1: ``P[..., i, j] = {z_i, z_j}``, ``z = (x, pi)``."""
        res = self.poisson_batch(f, theta, upsilon, x, pi)
        self._raise_outside(res.outside_chart, "poisson_tensor")
        refuse_overflow("poisson_tensor", {"P": res.P}, res.degenerate, "Upsilon = 0" in res.path)
        self._raise_degenerate(res.degenerate, "poisson_tensor")
        return res.P

    def hamiltonian_vector_field(self, f, theta, upsilon, inertia, potential, x, pi):
        """Protocol method 2: ``(xdot, pidot)`` with the leading axes of ``x``."""
        res = self.vector_field_batch(f, theta, upsilon, inertia, potential, x, pi)
        self._raise_outside(res.outside_chart, "hamiltonian_vector_field")
        pair = {"xdot": res.xdot, "pidot": res.pidot}  # issue 30 hook: overflow refused as such
        refuse_overflow("hamiltonian_vector_field", pair, res.degenerate, False)
        self._raise_degenerate(res.degenerate, "hamiltonian_vector_field")
        return res.xdot, res.pidot


def _expm_batch(A: np.ndarray, su2: bool) -> np.ndarray:
    """``Ad(g) = exp(ad_x)`` for a batch: Rodrigues for su(2), scaling and squaring otherwise."""
    n = A.shape[-1]
    if su2:
        t2 = -0.5 * np.einsum("Nij,Nji->N", A, A)  # tr(K^2) = -2 t^2
        t = np.sqrt(t2)
        small = t < 1e-4
        ts = np.where(small, 1.0, t)
        s1 = np.where(small, 1 - t2 / 6, np.sin(ts) / ts)
        s2 = np.where(small, 0.5 - t2 / 24, (1 - np.cos(ts)) / (ts * ts))
        return np.eye(n) + s1[:, None, None] * A + s2[:, None, None] * (A @ A)
    finite = np.isfinite(A).all(axis=(-2, -1))
    if not finite.all():  # a diverged stage of an implicit step: NaN there, the others computed
        out = np.full(A.shape, np.nan)
        if finite.any():
            out[finite] = _expm_batch(A[finite], su2)
        return out
    norm = float(np.max(_frob(A))) if A.size else 0.0
    s = max(0, int(np.ceil(np.log2(max(norm, 1e-300) / 0.25))))
    X = A / 2.0**s
    coeffs = np.array([1.0 / np.prod(np.arange(1, k + 1, dtype=float)) for k in range(18)])
    E = ps_poly(X, coeffs, np.eye(n))
    for _ in range(s):
        E = E @ E
    return E
