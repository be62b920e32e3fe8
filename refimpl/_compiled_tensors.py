"""Compiled (numba) Poisson tensors: the su(2) closed form and the generic path (vier9), per point.

Same mathematics, same per-point diagnostics and the same error model as the numpy kernels of
:mod:`refimpl._fast_kernels` (stated in :mod:`refimpl.fast`): every quantity the numpy path forms for
a batch is formed here for one point at a time, in registers and small scratch matrices, and written
straight into the caller's output layout. The output is any ``(N, 2n, 2n)`` view: points-major
(``P[k, i, j]``, the protocol's layout) or a transposed view of a components-first ``(2n, 2n, N)``
array; the inputs ``x``, ``pi`` are ``(N, n)`` views in the same way. No transposing copy is made.

What is compiled (issue 14: per structure, never per model)
    * ``su2``: one kernel for every su(2) model; ``xi`` (from Theta) and ``tau`` (from Upsilon) are
      arguments, and whether each is present is a run-time flag (a branch per point, no code per
      model).
    * ``generic``: one kernel for every algebra: the dimension ``n`` is read from the arrays, ``f``,
      ``Theta``, ``Upsilon`` and the Bernoulli and phi1 coefficients are arguments, the presence of
      Theta and Upsilon run-time flags. (A literal ``n`` per dimension was measured 13% faster on
      su(3) at 10^5 points, but costs a 6-8 s compilation per dimension on a cold cache: six
      dimensions in the catalogue.)

    The sources are written once into the Taylor kernels' cache directory
    (:func:`refimpl._compiled_taylor.cache_dir`, ``$TSTARG_CACHE_DIR``) under the hash of their text
    and compiled with ``cache=True``, so a second process loads machine code instead of compiling.
    :func:`compile_count` says how many kernels this process compiled and how many it loaded.

Differences from the numpy path (all inside the same error model)
    * The frame series sums, per point, the number of Bernoulli terms that point's own ``r`` needs
      (the numpy path uses the largest ``r`` of a bin of points); the tail bound
      ``3.3 r^(2K+2)/(1 - r^2) <= eps/8`` holds for every point either way.
    * ``phi1`` by scaling and squaring scales each point by its own Frobenius norm (numpy: the batch's
      largest), and the inverses (``Psi^-1``, ``phi1^-1``) are an LU factorization with partial
      pivoting and one triangular solve pair per column (numpy: LAPACK ``getrf``/``getri``); an
      exactly zero pivot gives NaN, as numpy's per-point fallback does. (Gauss-Jordan elimination,
      tried first, is not backward stable: on se(3) at |pi| ~ 1e6 it lost four more digits in
      ``S Psi^-1`` and broke the bound; tests/test_compiled_tensors.py keeps that point.)
    * Points on the chart edge: the kernel computes the norm bound ``||ad_x||_2 <= min(||.||_F,
      sqrt(||.||_1 ||.||_inf))`` it needs anyway; only points where that bound reaches the edge are
      handed to :func:`refimpl._validate.outside_chart` (eigenvalues), and those are recomputed at
      ``x = 0`` exactly as the numpy path does, then marked NaN with an infinite bound.

Without numba (``HAVE_NUMBA`` False) nothing here runs and :mod:`refimpl._fast_kernels` keeps the
numpy path; :data:`PATH` and the ``path`` field of every result say which path ran.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import sys

import numpy as np

from ._compiled_taylor import HAVE_NUMBA, cache_dir

__all__ = ["HAVE_NUMBA", "PATH", "compile_count", "generic_poisson", "su2_poisson"]

PATH = "numba" if HAVE_NUMBA else "numpy"

# ------------------------------------------------------------------------------- the su(2) kernel
# One point per iteration; the formulas, their order and the bound are those of
# refimpl._fast_kernels._su2_poisson_chunk and _su2_frame_coeffs (see their comments).
_SU2_SRC = """
import math
import numpy as np
from numba import njit, types

EPS = {EPS!r}
# inputs are read-only views of any layout (the caller's arrays, never written); outputs writable
R1 = types.Array(types.float64, 1, "A", readonly=True)
R2 = types.Array(types.float64, 2, "A", readonly=True)
I2 = types.Array(types.int64, 2, "A", readonly=True)
W1 = types.Array(types.float64, 1, "A")
W3 = types.Array(types.float64, 3, "A")
B1 = types.Array(types.boolean, 1, "A")
b1 = types.boolean
C_P = {C_P!r}
TWO_PI = {TWO_PI!r}


@njit(
    types.void(R2, R2, R1, b1, R1, b1, W3, W1, W1, W1, B1, B1),
    cache=True,
    nogil=True,
    error_model="numpy",
)
def su2(x, p, xi, has_xi, tau, has_tau, out, cond, sens, bound, degen, outside):
    N = x.shape[0]
    tn2 = tau[0] * tau[0] + tau[1] * tau[1] + tau[2] * tau[2]
    tn = math.sqrt(tn2)
    nan = np.nan
    inf = np.inf
    for k in range(N):
        x0 = x[k, 0]
        x1 = x[k, 1]
        x2 = x[k, 2]
        q0 = p[k, 0]
        q1 = p[k, 1]
        q2 = p[k, 2]
        if has_xi:
            q0 += xi[0]
            q1 += xi[1]
            q2 += xi[2]
        t2 = x0 * x0 + x1 * x1 + x2 * x2
        t = math.sqrt(t2)
        # chart (refimpl._validate.outside_chart for su(2)): rho = |x|, err = 48 eps rho
        off = not (t + 16 * 3 * EPS * t < TWO_PI)
        outside[k] = off
        if off:  # computed at x = 0 as the numpy path does, then marked NaN by the caller
            x0 = 0.0
            x1 = 0.0
            x2 = 0.0
            t2 = 0.0
            t = 0.0
        if t < 0.25:
            w = t2
            c = 1 / 12 + w * (
                1 / 720
                + w * (1 / 30240 + w * (1 / 1209600 + w * (1 / 47900160 + w * (691 / 1307674368000))))
            )
            lam = math.sqrt(
                1 + w * (1 / 12 + w * (1 / 240 + w * (1 / 6048 + w * (1 / 172800 + w * (1 / 5322240)))))
            )
            kk = 1 / 6 + w * (
                1 / 180
                + w * (1 / 5040 + w * (1 / 151200 + w * (1 / 4790016 + w * (691 / 108972864000))))
            )
        else:
            h = 0.5 * t
            u = math.tan(0.5 * h)
            u2 = u * u
            r = h / (u + u)
            om = 1.0 - u2
            v = 1.0 + u2
            c = (1.0 - r * om) / (t * t)
            lam = r * v
            kk = (t * v * v - 4.0 * u * om) / (16.0 * t * u2)
        d = 1.0 - c * t2
        if has_tau:
            qt = tau[0] * q0 + tau[1] * q1 + tau[2] * q2
            c1 = 1.0 - qt
            ic = 1.0 / c1
            dd = d * ic
            cc = c * ic
            hh = 0.5 * ic
        else:
            c1 = 1.0
            ic = 1.0
            dd = d
            cc = c
            hh = 0.5
        cx0 = cc * x0
        cx1 = cc * x1
        cx2 = cc * x2
        hx0 = hh * x0
        hx1 = hh * x1
        hx2 = hh * x2
        s01 = cx0 * x1
        s02 = cx0 * x2
        s12 = cx1 * x2
        # L (scaled by 1/C1 with Upsilon)
        L00 = cx0 * x0 + dd
        L11 = cx1 * x1 + dd
        L22 = cx2 * x2 + dd
        L01 = s01 - hx2
        L10 = s01 + hx2
        L02 = s02 + hx1
        L20 = s02 - hx1
        L12 = s12 - hx0
        L21 = s12 + hx0
        frame = t * (-1.0 / TWO_PI) + 1.0
        if frame < EPS:
            frame = EPS
        if not has_tau:
            out[k, 0, 0] = 0.0
            out[k, 0, 1] = 0.0
            out[k, 0, 2] = 0.0
            out[k, 1, 0] = 0.0
            out[k, 1, 1] = 0.0
            out[k, 1, 2] = 0.0
            out[k, 2, 0] = 0.0
            out[k, 2, 1] = 0.0
            out[k, 2, 2] = 0.0
            out[k, 0, 3] = L00
            out[k, 0, 4] = L01
            out[k, 0, 5] = L02
            out[k, 1, 3] = L10
            out[k, 1, 4] = L11
            out[k, 1, 5] = L12
            out[k, 2, 3] = L20
            out[k, 2, 4] = L21
            out[k, 2, 5] = L22
            out[k, 3, 0] = -L00
            out[k, 3, 1] = -L10
            out[k, 3, 2] = -L20
            out[k, 4, 0] = -L01
            out[k, 4, 1] = -L11
            out[k, 4, 2] = -L21
            out[k, 5, 0] = -L02
            out[k, 5, 1] = -L12
            out[k, 5, 2] = -L22
            out[k, 3, 3] = 0.0
            out[k, 3, 4] = -q2
            out[k, 3, 5] = q1
            out[k, 4, 3] = q2
            out[k, 4, 4] = 0.0
            out[k, 4, 5] = -q0
            out[k, 5, 3] = -q1
            out[k, 5, 4] = q0
            out[k, 5, 5] = 0.0
            cond[k] = 1.0
            sens[k] = 1.0
            # |P| <= max(lam^2, |q|_max): bound = 3 C_P eps max(lam^2, |q|) / frame
            qa = max(abs(q0), abs(q1), abs(q2))
            lam2 = lam * lam
            if qa > lam2:
                lam2 = qa
            bound[k] = lam2 * (C_P * 3 * EPS) / frame
            degen[k] = False
            continue
        # ---- Upsilon = tau.eps: P_xp = (L - (L q) tau^T) / C1, P_pp = [q]_x / C1,
        # P_xx = [d tau + k (x.tau) x + (x * tau)/2]_x / C1
        lq0 = L00 * q0 + L01 * q1 + L02 * q2
        lq1 = L10 * q0 + L11 * q1 + L12 * q2
        lq2 = L20 * q0 + L21 * q1 + L22 * q2
        L00 -= lq0 * tau[0]
        L01 -= lq0 * tau[1]
        L02 -= lq0 * tau[2]
        L10 -= lq1 * tau[0]
        L11 -= lq1 * tau[1]
        L12 -= lq1 * tau[2]
        L20 -= lq2 * tau[0]
        L21 -= lq2 * tau[1]
        L22 -= lq2 * tau[2]
        w0 = 0.5 * (tau[2] * x1 - tau[1] * x2)
        w1 = 0.5 * (tau[0] * x2 - tau[2] * x0)
        w2 = 0.5 * (tau[1] * x0 - tau[0] * x1)
        kt = kk * (tau[0] * x0 + tau[1] * x1 + tau[2] * x2)
        w0 = (w0 + kt * x0 + d * tau[0]) * ic
        w1 = (w1 + kt * x1 + d * tau[1]) * ic
        w2 = (w2 + kt * x2 + d * tau[2]) * ic
        qi0 = q0 * ic
        qi1 = q1 * ic
        qi2 = q2 * ic
        aic = abs(ic)
        qn2 = q0 * q0 + q1 * q1 + q2 * q2
        tq = qn2 * tn2
        nf2 = (3.0 * c1 + 2.0 * qt) * c1 + tq
        ni2 = tq - 2.0 * qt + 3.0
        cnd = math.sqrt(nf2 * ni2) * aic * (1.0 / 3.0)
        qn = math.sqrt(qn2)
        sn = math.sqrt(ni2) * ((qn * (2.0 * tn) + 1.0) * (aic * (1.0 / math.sqrt(3.0))))
        sc = ((lam * tn + 1.0) * lam * lam + lam * (1 + qn * tn) + qn) * aic
        if sc < 1.0:
            sc = 1.0
        bnd = sc * sn / frame * (C_P * 3 * EPS)
        bad = (not (sn < 1.0 / (3 * C_P * EPS))) or c1 == 0
        degen[k] = bad
        if bad:
            for i in range(6):
                for j in range(6):
                    out[k, i, j] = nan
            bound[k] = inf
            cond[k] = inf
            sens[k] = inf
            continue
        cond[k] = cnd
        sens[k] = sn
        bound[k] = bnd
        out[k, 0, 0] = 0.0
        out[k, 0, 1] = -w2
        out[k, 0, 2] = w1
        out[k, 1, 0] = w2
        out[k, 1, 1] = 0.0
        out[k, 1, 2] = -w0
        out[k, 2, 0] = -w1
        out[k, 2, 1] = w0
        out[k, 2, 2] = 0.0
        out[k, 0, 3] = L00
        out[k, 0, 4] = L01
        out[k, 0, 5] = L02
        out[k, 1, 3] = L10
        out[k, 1, 4] = L11
        out[k, 1, 5] = L12
        out[k, 2, 3] = L20
        out[k, 2, 4] = L21
        out[k, 2, 5] = L22
        out[k, 3, 0] = -L00
        out[k, 3, 1] = -L10
        out[k, 3, 2] = -L20
        out[k, 4, 0] = -L01
        out[k, 4, 1] = -L11
        out[k, 4, 2] = -L21
        out[k, 5, 0] = -L02
        out[k, 5, 1] = -L12
        out[k, 5, 2] = -L22
        out[k, 3, 3] = 0.0
        out[k, 3, 4] = -qi2
        out[k, 3, 5] = qi1
        out[k, 4, 3] = qi2
        out[k, 4, 4] = 0.0
        out[k, 4, 5] = -qi0
        out[k, 5, 3] = -qi1
        out[k, 5, 4] = qi0
        out[k, 5, 5] = 0.0
"""

# --------------------------------------------------------------------------- the generic kernel
# One point per iteration, n = x.shape[1] at run time; the formulas are those of
# refimpl._fast_kernels._generic_poisson_chunk, _frames_generic, _summand_norms (see there).
_GENERIC_SRC = """
import math
import numpy as np
from numba import njit, types

EPS = {EPS!r}
# inputs are read-only views of any layout (the caller's arrays, never written); outputs writable
R1 = types.Array(types.float64, 1, "A", readonly=True)
R2 = types.Array(types.float64, 2, "A", readonly=True)
I2 = types.Array(types.int64, 2, "A", readonly=True)
W1 = types.Array(types.float64, 1, "A")
W3 = types.Array(types.float64, 3, "A")
B1 = types.Array(types.boolean, 1, "A")
b1 = types.boolean
C_P = {C_P!r}
TWO_PI = {TWO_PI!r}
SERIES_MAX = {SERIES_MAX!r}


@njit(cache=True, nogil=True)
def _mm(a, b, c):
    NDIM = a.shape[0]
{MM_BODY}


@njit(cache=True, nogil=True)
def _frob(a):
    NDIM = a.shape[0]
    s = 0.0
    for i in range(NDIM):
        for j in range(NDIM):
            s += a[i, j] * a[i, j]
    return math.sqrt(s)


@njit(cache=True, nogil=True)
def _inv(a, w, perm, out):
    # out = a^-1 as LAPACK getrf + solves: LU with partial pivoting on the scratch w, then a forward
    # and a back substitution per column of the identity (each column backward stable; Gauss-Jordan
    # is not, and lost 4 more digits in S Psi^-1 at |pi| ~ 1e6). NaN at an exactly zero pivot.
    NDIM = a.shape[0]
    for i in range(NDIM):
        perm[i] = i
        for j in range(NDIM):
            w[i, j] = a[i, j]
    for col in range(NDIM):
        piv = col
        best = abs(w[col, col])
        for i in range(col + 1, NDIM):
            v = abs(w[i, col])
            if v > best:
                best = v
                piv = i
        if not best > 0.0:
            for i in range(NDIM):
                for j in range(NDIM):
                    out[i, j] = np.nan
            return
        if piv != col:
            for j in range(NDIM):
                tmp = w[col, j]
                w[col, j] = w[piv, j]
                w[piv, j] = tmp
            t = perm[col]
            perm[col] = perm[piv]
            perm[piv] = t
        d = w[col, col]
        for i in range(col + 1, NDIM):
            m = w[i, col] / d
            w[i, col] = m
            if m != 0.0:
                for j in range(col + 1, NDIM):
                    w[i, j] -= m * w[col, j]
    for c in range(NDIM):
        # column c of a^-1: solve L U y = e_(perm^-1 c)
        for i in range(NDIM):
            b = 1.0 if perm[i] == c else 0.0
            for k in range(i):
                b -= w[i, k] * out[k, c]
            out[i, c] = b
        for i in range(NDIM - 1, -1, -1):
            b = out[i, c]
            for k in range(i + 1, NDIM):
                b -= w[i, k] * out[k, c]
            out[i, c] = b / w[i, i]


@njit(cache=True, nogil=True)
def _poly(W, coeffs, K, pows, acc, blk, tmp, Ws):
    NDIM = W.shape[0]
    # acc = sum_{k=0..K} coeffs[k] W^k by Paterson-Stockmeyer (as refimpl._fast_kernels._ps_poly)
    s = max(1, int(math.ceil(math.sqrt(K + 1))))
    nb = K // s + 1
    for i in range(NDIM):
        for j in range(NDIM):
            pows[0, i, j] = 1.0 if i == j else 0.0
    if s > 1:
        for i in range(NDIM):
            for j in range(NDIM):
                pows[1, i, j] = W[i, j]
    for m in range(2, s):
        _mm(pows[m - 1], W, pows[m])
    if s > 1:
        _mm(pows[s - 1], W, Ws)
    else:
        for i in range(NDIM):
            for j in range(NDIM):
                Ws[i, j] = W[i, j]
    for b in range(nb - 1, -1, -1):
        for i in range(NDIM):
            for j in range(NDIM):
                blk[i, j] = 0.0
        for m in range(s):
            kk = b * s + m
            if kk <= K:
                cf = coeffs[kk]
                for i in range(NDIM):
                    for j in range(NDIM):
                        blk[i, j] += cf * pows[m, i, j]
        if b == nb - 1:
            for i in range(NDIM):
                for j in range(NDIM):
                    acc[i, j] = blk[i, j]
        else:
            _mm(acc, Ws, tmp)
            for i in range(NDIM):
                for j in range(NDIM):
                    acc[i, j] = tmp[i, j] + blk[i, j]


@njit(
    types.void(I2, R1, R2, b1, R2, b1, R1, R1, R2, R2, W3, W1, W1, W1, B1, W1),
    cache=True,
    nogil=True,
    error_model="numpy",
)
def generic(fidx, fval, theta, has_theta, ups, has_ups, bern, phi1c, x, p, out,
            cond, sens, bound, degen, rr):
    # f enters as its nonzero entries f[fidx[e, 0], fidx[e, 1], fidx[e, 2]] = fval[e]
    N = x.shape[0]
    NDIM = x.shape[1]
    n = NDIM
    A = np.empty((n, n))
    W = np.empty((n, n))
    L = np.empty((n, n))
    S = np.empty((n, n))
    Psi = np.empty((n, n))
    Pi = np.empty((n, n))
    Pxp = np.empty((n, n))
    T1 = np.empty((n, n))
    T2 = np.empty((n, n))
    T3 = np.empty((n, n))
    T4 = np.empty((n, n))
    T5 = np.empty((n, n))
    pows = np.empty((8, n, n))
    perm = np.empty(n, dtype=np.int64)
    nnz = fval.shape[0]
    absth = np.abs(theta)
    un = 0.0
    for i in range(n):
        for j in range(n):
            un += ups[i, j] * ups[i, j]
    un = math.sqrt(un)
    for k in range(N):
        # ad_x[i, j] = sum_a x_a f^i_aj ; S[a, b] = sum_m pi_m f^m_ab - Theta_ab ; summand magnitudes
        for i in range(n):
            for j in range(n):
                A[i, j] = 0.0
                S[i, j] = 0.0
                T1[i, j] = 0.0
                T2[i, j] = 0.0
        for e in range(nnz):
            i = fidx[e, 0]
            a = fidx[e, 1]
            j = fidx[e, 2]
            v = fval[e]
            av = abs(v)
            A[i, j] += x[k, a] * v  # ad_x = sum_a x_a f^i_aj
            T2[i, j] += abs(x[k, a]) * av
            S[a, j] += p[k, i] * v  # S_aj = sum_i pi_i f^i_aj
            T1[a, j] += abs(p[k, i]) * av
        if has_theta:
            for i in range(n):
                for j in range(n):
                    S[i, j] -= theta[i, j]
                    T1[i, j] += absth[i, j]
        Sabs = _frob(T1)
        Aabs = _frob(T2)
        # r >= ||ad_x||_2 / 2 pi
        fro = _frob(A)
        n1 = 0.0
        ninf = 0.0
        for i in range(n):
            cs = 0.0
            rs = 0.0
            for j in range(n):
                cs += abs(A[j, i])
                rs += abs(A[i, j])
            if cs > n1:
                n1 = cs
            if rs > ninf:
                ninf = rs
        r = min(fro, math.sqrt(n1 * ninf)) / TWO_PI
        rr[k] = r
        if r <= SERIES_MAX:
            # L = B(ad_x): even Bernoulli series in W = ad_x^2 (tail <= eps/8), plus ad_x / 2
            if r <= 0:
                K = 1
            else:
                target = EPS / 8 * (1 - r * r) / 3.3
                K = max(1, int(math.ceil((math.log(target) / math.log(r) - 2) / 2)))
            _mm(A, A, W)
            _poly(W, bern, K, pows, L, T1, T2, T3)
            for i in range(n):
                for j in range(n):
                    L[i, j] += 0.5 * A[i, j]
        elif not fro < 1e300:  # overflowing ad_x: far outside the chart (the caller marks it)
            for i in range(n):
                for j in range(n):
                    L[i, j] = np.nan
        else:
            # L = phi1(-ad_x)^-1: Taylor of degree 16 on M / 2^s, phi1(2X) = phi1(X)(e^X + 1)/2
            nm = fro
            if nm < 1e-300:
                nm = 1e-300
            s = max(0, int(math.ceil(math.log2(nm / 0.25))))
            sc = 1.0 / 2.0**s
            for i in range(n):
                for j in range(n):
                    W[i, j] = -A[i, j] * sc
            _poly(W, phi1c, 16, pows, T4, T1, T2, T3)
            _mm(W, T4, T5)
            for i in range(n):
                T5[i, i] += 1.0  # E = 1 + X T
            for it in range(s):
                for i in range(n):
                    for j in range(n):
                        T1[i, j] = T5[i, j]
                    T1[i, i] += 1.0
                _mm(T4, T1, T2)
                for i in range(n):
                    for j in range(n):
                        T4[i, j] = 0.5 * T2[i, j]
                if it < s - 1:
                    _mm(T5, T5, T2)
                    for i in range(n):
                        for j in range(n):
                            T5[i, j] = T2[i, j]
            _inv(T4, T1, perm, L)
        Lfin = True
        for i in range(n):
            for j in range(n):
                if not math.isfinite(L[i, j]):
                    Lfin = False
        if not has_ups:
            for i in range(n):
                for j in range(n):
                    out[k, i, j] = 0.0
                    out[k, i, n + j] = L[i, j]
                    out[k, n + j, i] = -L[i, j]
                    out[k, n + i, n + j] = -S[i, j]
            cnd = 1.0
            sn = 1.0
        else:
            # Psi = 1 + U S, Pxp = L Psi^-1, Ppp = -S Psi^-1, Pxx = -(Pxp U) L^T (vier9)
            _mm(ups, S, Psi)
            for i in range(n):
                Psi[i, i] += 1.0
            _inv(Psi, T1, perm, Pi)
            sn = _frob(Pi) * (1 + _frob(S) * un) / math.sqrt(n)
            if not math.isfinite(sn):
                sn = np.inf
            _mm(L, Pi, Pxp)
            _mm(S, Pi, T2)  # -Ppp
            _mm(Pxp, ups, T1)
            # T3 = -(T1 L^T)
            for i in range(n):
                for j in range(n):
                    acc = 0.0
                    for l in range(n):
                        acc += T1[i, l] * L[j, l]
                    T3[i, j] = -acc
            for i in range(n):
                for j in range(n):
                    out[k, i, j] = 0.5 * (T3[i, j] - T3[j, i])
                    out[k, i, n + j] = Pxp[i, j]
                    out[k, n + j, i] = -Pxp[i, j]
                    out[k, n + i, n + j] = 0.5 * (T2[j, i] - T2[i, j])
            cnd = _frob(Psi) * _frob(Pi) / n
        if not math.isfinite(cnd):
            cnd = np.inf
        frame = 1.0 / max(1.0 - min(r, 1.0), EPS)
        pmax = 0.0
        for i in range(2 * n):
            for j in range(2 * n):
                v = abs(out[k, i, j])
                if not v <= pmax:  # NaN propagates, as np.max does
                    pmax = v
        scale = max(pmax, 1.0)
        eff = max(cnd, sn)
        if not has_ups:
            data = n * Sabs
        else:
            # first order in dS: ||L U Phi^-1||_F^2 + ||Phi^-1||_F^2, Phi^-1 = Psi^-T; since
            # U Phi^-1 = Psi^-1 U, L U Phi^-1 = Pxp U, still in T1
            fl = _frob(T1)
            fp = _frob(Pi)
            data = Sabs * (fl * fl + fp * fp)
        bnd = C_P * n * EPS * frame * (eff * scale + data + Aabs * pmax)
        bad = (not (eff * (n * C_P * EPS) < 1.0)) or not Lfin
        degen[k] = bad
        if bad:
            for i in range(2 * n):
                for j in range(2 * n):
                    out[k, i, j] = np.nan
            bnd = np.inf
            cnd = np.inf
            sn = np.inf
        cond[k] = cnd
        sens[k] = sn
        bound[k] = bnd
"""

_MODULES: dict = {}


def _module(name: str, src: str):
    """Import the kernel module of ``src``, written once into the cache directory under its hash
    (numba keys its machine-code cache on the file, so an existing file is never rewritten)."""
    key = hashlib.sha1(src.encode()).hexdigest()[:20]
    modname = f"tensors_{name}_{key}"
    if modname in _MODULES:
        return _MODULES[modname]
    folder = cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{modname}.py"
    if not path.exists() or path.read_text() != src:
        tmp = folder / f".{modname}.{os.getpid()}.tmp"
        tmp.write_text(src)
        os.replace(tmp, path)
    if str(folder) not in sys.path:
        sys.path.append(str(folder))
    mod = importlib.import_module(modname)
    _MODULES[modname] = mod
    return mod


def _fill(src: str, consts: dict) -> str:
    """The kernel source with the error model's constants (``EPS``, ``C_P``, ``TWO_PI``,
    ``SERIES_MAX``, given by :mod:`refimpl._fast_kernels`) written in as literals."""
    for k in ("EPS", "C_P", "TWO_PI", "SERIES_MAX"):
        src = src.replace("{" + k + "!r}", repr(float(consts[k])))
    return src


_BY_CONSTS: dict = {}


def _su2_module(consts: dict):
    key = ("su2", *consts.items())
    if key not in _BY_CONSTS:
        _BY_CONSTS[key] = _module("su2", _fill(_SU2_SRC, consts))
    return _BY_CONSTS[key]


SPECIALISE_FROM = 6
"""Dimensions from which the generic kernel is compiled for its dimension: ``n`` becomes a literal and
the ``n x n`` products keep each row of the result in ``n`` named accumulators (registers, packed
into SIMD lanes by the compiler) instead of in memory, which the compiler must reload and store at
every term because it cannot prove the arrays distinct. One more compilation per dimension, repaid
where the per-point cost is highest (``n >= 6``: se(3), su(3), sl(3,R)); smaller algebras share one
kernel with ``n`` read at run time. Every entry is summed in the same order either way."""

_MM_LOOP = """    # c = a @ b (n x n)
    for i in range(NDIM):
        for j in range(NDIM):
            c[i, j] = 0.0
        for l in range(NDIM):
            ail = a[i, l]
            for j in range(NDIM):
                c[i, j] += ail * b[l, j]"""


def _mm_unrolled(n: int) -> str:
    """The body of ``_mm`` for dimension ``n``: row ``i`` of ``a @ b`` in the accumulators ``c0..c{n-1}``,
    terms added in the order ``l = 0, 1, ...`` (as the loop form)."""
    acc = ", ".join(f"c{j}" for j in range(n))
    lines = [f"    # c = a @ b ({n} x {n}), row by row in registers", f"    for i in range({n}):"]
    lines.append(f"        {acc} = {', '.join('0.0' for _ in range(n))}")
    lines.append(f"        for l in range({n}):")
    lines.append("            ail = a[i, l]")
    lines += [f"            c{j} += ail * b[l, {j}]" for j in range(n)]
    lines += [f"        c[i, {j}] = c{j}" for j in range(n)]
    return "\n".join(lines)


def _generic_source(consts: dict, n: int | None) -> str:
    """The generic kernel's source: ``n`` read at run time (None), or written in for dimension ``n``
    with the products of :func:`_mm_unrolled`."""
    src = _fill(_GENERIC_SRC, consts)
    src = src.replace("{MM_BODY}", _MM_LOOP if n is None else _mm_unrolled(int(n)))
    if n is not None:
        for arr in ("a.shape[0]", "W.shape[0]", "x.shape[1]"):
            src = src.replace(f"NDIM = {arr}", f"NDIM = {int(n)}")
    return src


def _generic_module(consts: dict, n: int | None = None):
    dim = int(n) if n is not None and n >= SPECIALISE_FROM else None
    key = ("generic", dim, *consts.items())
    if key not in _BY_CONSTS:
        name = "generic" if dim is None else f"generic{dim}"
        _BY_CONSTS[key] = _module(name, _generic_source(consts, dim))
    return _BY_CONSTS[key]


def su2_poisson(x, p, xi, tau, out, cond, sens, bound, degen, outside, *, consts: dict) -> None:
    """The su(2) closed form for ``x``, ``p`` (``(N, 3)`` views) into ``out`` (an ``(N, 6, 6)`` view).

    ``xi`` (Theta) and ``tau`` (Upsilon) are 3-vectors or None. ``outside`` receives the chart mask;
    the caller marks those points (they are computed at ``x = 0``). ``consts``: see :func:`_fill`."""
    mod = _su2_module(consts)
    z = np.zeros(3)
    mod.su2(
        x,
        p,
        z if xi is None else np.asarray(xi, dtype=float),
        xi is not None,
        z if tau is None else np.asarray(tau, dtype=float),
        tau is not None,
        out,
        cond,
        sens,
        bound,
        degen,
        outside,
    )


def generic_poisson(
    f, theta, upsilon, x, p, out, cond, sens, bound, degen, *, bern, consts: dict
) -> np.ndarray:
    """The generic path for ``x``, ``p`` (``(N, n)`` views) into ``out`` (an ``(N, 2n, 2n)`` view).

    ``bern``: ``1, B_2/2!, B_4/4!, ...`` with enough terms for ``r = SERIES_MAX``; ``consts``: see
    :func:`_fill`. Returns ``r >= ||ad_x||_2 / 2 pi`` per point (the caller's chart pre-filter)."""
    n = f.shape[0]
    mod = _generic_module(consts, n)
    fc = np.ascontiguousarray(f, dtype=float)
    fidx = np.argwhere(fc != 0).astype(np.int64).reshape(-1, 3)
    fval = fc[fc != 0]
    phi1c = _phi1_coeffs()
    z = np.zeros((n, n))
    r = np.empty(x.shape[0])
    mod.generic(
        fidx,
        fval,
        z if theta is None else np.ascontiguousarray(theta, dtype=float),
        theta is not None,
        z if upsilon is None else np.ascontiguousarray(upsilon, dtype=float),
        upsilon is not None,
        bern,
        phi1c,
        x,
        p,
        out,
        cond,
        sens,
        bound,
        degen,
        r,
    )
    return r


_PHI1 = None


def _phi1_coeffs() -> np.ndarray:
    """``1/(k+1)!`` for ``k = 0..16`` (the Taylor coefficients of phi1, as the numpy path)."""
    global _PHI1
    if _PHI1 is None:
        _PHI1 = np.array([1.0 / np.prod(np.arange(2, k + 2, dtype=float)) for k in range(17)])
    return _PHI1


def compile_count() -> dict:
    """Kernels of this process: ``compiled`` (machine code made here), ``loaded`` (from the disk
    cache), ``structures`` (kernel modules imported). Zeros without numba."""
    out = {"compiled": 0, "loaded": 0, "structures": len(_MODULES)}
    for mod in _MODULES.values():
        for name in ("su2", "generic"):
            disp = getattr(mod, name, None)
            if disp is None:
                continue
            out["compiled"] += sum(disp._cache_misses.values())
            out["loaded"] += sum(disp._cache_hits.values())
    return out
