"""Template of the compiled generic Poisson tensor kernel (:func:`refimpl.codegen.tensors.generic_source`).

Read as text by :func:`refimpl.codegen._loader.template`: the lines above the body mark only
define the placeholders for the linters; ``__NAME__`` is replaced by :func:`refimpl.codegen._loader.fill`
(a placeholder alone on its line replaces the whole line)."""

# The body is the generated text byte for byte (its hash is the kernels' cache key): the
# formatter leaves it alone, and the import layout and names used only by generated code are kept.
# ruff: noqa: E402, I001, F401, F841
# fmt: off
__EPS__ = None
__C_P__ = None
__TWO_PI__ = None
__SERIES_MAX__ = None
__MM_BODY__ = None
# ---- template body ----

import math
import numpy as np
from numba import njit, types

EPS = __EPS__
# inputs are read-only views of any layout (the caller's arrays, never written); outputs writable
R1 = types.Array(types.float64, 1, "A", readonly=True)
R2 = types.Array(types.float64, 2, "A", readonly=True)
I2 = types.Array(types.int64, 2, "A", readonly=True)
W1 = types.Array(types.float64, 1, "A")
W3 = types.Array(types.float64, 3, "A")
B1 = types.Array(types.boolean, 1, "A")
b1 = types.boolean
C_P = __C_P__
TWO_PI = __TWO_PI__
SERIES_MAX = __SERIES_MAX__


@njit(cache=True, nogil=True)
def _mm(a, b, c):
    NDIM = a.shape[0]
    __MM_BODY__


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
    K16 = np.int64(16)  # phi1's degree; a literal 16 compiled _poly a second time (Literal[int])
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
            _poly(W, phi1c, K16, pows, T4, T1, T2, T3)
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
