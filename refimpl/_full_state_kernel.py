"""The compiled kernel of :mod:`refimpl._full_state`: one machine-code function for every structure.

The field is given as sparse tables (arguments, never literals), so numba compiles this module once
per argument types -- once in total -- and ``cache=True`` keeps the machine code on disk: a new
algebra, inertia or representation costs no compilation at all.

Tables (all ``int64`` unless said otherwise; ``V`` is the ``(nv, P + 1)`` array of Taylor coefficients,
rows ``0..d-1`` the state, then the derived rows):

``drow, dptr, didx, dcoef``
    derived (linear) rows in dependency order: ``V[drow[r], k] = sum_t dcoef[t] V[didx[t], k]``,
    ``t`` in ``dptr[r]..dptr[r+1]`` (``Omega = I^-1 pi``, then ``M = rho(Omega)``);
``pu, pw, pcls``
    the Cauchy products ``p = sum_{a<=k} V[pu, a] V[pw, k - a]``; ``pcls`` 0 general, 1 ``pu``
    constant (only ``a = 0``), 2 ``pw`` constant, 3 both constant, 4 a square (half the terms twice);
``vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon``
    per non-constant state row ``vrow[c]``: ``V[vrow[c], k+1] = (sum qcoef p[qprod] + sum lcoef
    V[lvar, k]) / (k + 1)`` (``lcon``: the linear factor is constant, its ``k >= 1`` terms vanish);
``srow``
    the rows whose last two coefficients set the step (Jorba-Zou), and whose size scales the tolerance.

The step: Jorba and Zou's, as :mod:`refimpl._compiled_taylor` (``h = e^(-0.7/(P-1)) min((eps s /
||Y_{P-1}||)^(1/(P-1)), (eps s / ||Y_P||)^(1/P))``, ``s = max(1, ||y||)``), the update by Horner's rule
added with Kahan's compensation.
"""

from __future__ import annotations

import math

import numpy as np

try:
    from numba import njit
except ImportError:  # pragma: no cover - the plain-Python path

    def njit(*a, **kw):
        return (lambda fn: fn) if not a else a[0]


@njit(cache=True, nogil=True, fastmath={"contract"})
def coefficients(V, P, drow, dptr, didx, dcoef, pu, pw, pcls, pr, vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon):  # fmt: skip
    """The Taylor coefficients ``V[:, 1..P]`` of the state from ``V[:, 0]`` (the recurrence). The
    general products come first in ``pu``/``pw`` (``pcls`` 0), padded to a multiple of :data:`GROUP`
    with products of the zero row ``V[-1]``; each group's sums run side by side (independent chains,
    each summed in the order ``a = 0..k``), then the products with a constant factor."""
    nd = drow.shape[0]
    npr = pu.shape[0]
    ng = 0
    while ng < npr and pcls[ng] == 0:
        ng += 1
    nvar = vrow.shape[0]
    for k in range(P):
        for r in range(nd):
            acc = 0.0
            for t in range(dptr[r], dptr[r + 1]):
                acc += dcoef[t] * V[didx[t], k]
            V[drow[r], k] = acc
        for p in range(0, ng, 4):
            u0, u1, u2, u3 = pu[p], pu[p + 1], pu[p + 2], pu[p + 3]
            w0, w1, w2, w3 = pw[p], pw[p + 1], pw[p + 2], pw[p + 3]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = 0.0
            for a in range(k + 1):
                b = k - a
                s0 += V[u0, a] * V[w0, b]
                s1 += V[u1, a] * V[w1, b]
                s2 += V[u2, a] * V[w2, b]
                s3 += V[u3, a] * V[w3, b]
            pr[p] = s0
            pr[p + 1] = s1
            pr[p + 2] = s2
            pr[p + 3] = s3
        for p in range(ng, npr):
            c = pcls[p]
            if c == 1:
                pr[p] = V[pu[p], 0] * V[pw[p], k]
            elif c == 2:
                pr[p] = V[pu[p], k] * V[pw[p], 0]
            elif c == 3:
                pr[p] = V[pu[p], 0] * V[pw[p], 0] if k == 0 else 0.0
            else:
                pr[p] = 0.0
        ik = 1.0 / (k + 1)
        for c in range(nvar):
            acc = 0.0
            for t in range(qptr[c], qptr[c + 1]):
                acc += qcoef[t] * pr[qprod[t]]
            for t in range(lptr[c], lptr[c + 1]):
                if lcon[t]:
                    if k == 0:
                        acc += lcoef[t] * V[lvar[t], 0]
                else:
                    acc += lcoef[t] * V[lvar[t], k]
            V[vrow[c], k + 1] = acc * ik


@njit(cache=True, nogil=True, fastmath={"contract"})
def adaptive(y0, T, tol, P, max_steps, nv, drow, dptr, didx, dcoef, pu, pw, pcls, vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon, srow, out, nsteps):  # fmt: skip
    """Adaptive Taylor over ``[0, T]`` for every row of ``y0`` (N, d): ``out`` the end states,
    ``nsteps`` the steps (negative: -1 non-finite, -3 step budget, -4 no positive step)."""
    N, d = y0.shape
    V = np.zeros((nv + 1, P + 1))
    pr = np.zeros(max(pu.shape[0], 1))
    nvar = vrow.shape[0]
    comp = np.zeros(max(nvar, 1))
    sgn = 1.0 if T >= 0 else -1.0
    Tabs = abs(T)
    damp = math.exp(-0.7 / (P - 1))
    e1 = 1.0 / (P - 1)
    e2 = 1.0 / P
    for it in range(N):
        for q in range(d):
            V[q, 0] = y0[it, q]
        for q in range(nvar):
            comp[q] = 0.0
        t = 0.0
        nst = 0
        status = 0
        while t < Tabs:
            coefficients(V, P, drow, dptr, didx, dcoef, pu, pw, pcls, pr, vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon)  # fmt: skip
            xn = 0.0
            a1 = 0.0
            a2 = 0.0
            for q in range(srow.shape[0]):
                s_ = srow[q]
                xn = max(xn, abs(V[s_, 0]))
                a1 = max(a1, abs(V[s_, P - 1]))
                a2 = max(a2, abs(V[s_, P]))
            s = tol * max(1.0, xn)
            h = np.inf
            if a1 > 0.0:
                h = (s / a1) ** e1
            if a2 > 0.0:
                h = min(h, (s / a2) ** e2)
            h *= damp
            if not (h > 0.0):
                status = -4
                break
            if t + h >= Tabs:
                h = Tabs - t
                t = Tabs
            else:
                t += h
            hs = sgn * h
            fin = True
            for c in range(nvar):
                i = vrow[c]
                z = V[i, P]
                for kk in range(P - 1, 0, -1):
                    z = z * hs + V[i, kk]
                z = z * hs - comp[c]
                w = V[i, 0] + z
                comp[c] = (w - V[i, 0]) - z
                V[i, 0] = w
                if not math.isfinite(w):
                    fin = False
            nst += 1
            if not fin:
                status = -1
                break
            if nst > max_steps:
                status = -3
                break
        for q in range(d):
            out[it, q] = V[q, 0] if status == 0 else np.nan
        nsteps[it] = nst if status == 0 else status


# ---------------------------------------------------------------------- group-level helpers
# Small dense matrices of the representation (r <= ~10), real or complex: the exponential of rho(x0), the
# adjoint Ad(g) from G = rho(g), and the principal logarithm by inverse scaling and squaring -- the same
# mathematics as scipy's expm/logm used by refimpl._representation, without their per-call overhead
# (~0.1-5 ms on a 4 x 4 matrix; these run in microseconds). The caller falls back to
# Representation.log wherever the principal logarithm is not accepted (see _full_state._log_complete).


@njit(cache=True, nogil=True)
def _matmul(A, B, C):
    r = A.shape[0]
    for i in range(r):
        for j in range(r):
            acc = A[i, 0] * B[0, j]
            for k in range(1, r):
                acc += A[i, k] * B[k, j]
            C[i, j] = acc


@njit(cache=True, nogil=True)
def _norm1(A):
    r = A.shape[0]
    m = 0.0
    for j in range(r):
        s = 0.0
        for i in range(r):
            s += abs(A[i, j])
        m = max(m, s)
    return m


_INV_FACT = np.array([1.0 / math.factorial(k) for k in range(17)])
"""``1 / k!`` for ``k <= 16``, the Taylor coefficients of :func:`expm` (correctly rounded)."""


@njit(cache=True, nogil=True)
def expm(X, E):
    """``E = exp(X)``: the Taylor polynomial of degree 16 of ``Y = X / 2^s`` (``||Y||_1 <= 1/2``:
    truncation ``<= 0.5^17 / 17! e^0.5 < 4e-20`` of ``|exp Y| >= e^-0.5``), by Paterson and
    Stockmeyer's scheme (``Y^2, Y^3, Y^4``, then Horner in ``Y^4`` over blocks of four terms: six
    products of ``r x r`` matrices, where summing the series term by term to ``1e-18`` took up to
    sixteen), squared ``s`` times. Error model: tests/test_compiled_any_algebra.py's helper check
    (``100 eps exp(|X|_1) max(1, |exp X|)`` against mpmath)."""
    r = X.shape[0]
    nrm = _norm1(X)
    s = 0
    while nrm > 0.5:
        nrm *= 0.5
        s += 1
    sc = 0.5**s
    ws = np.empty((5,) + X.shape, dtype=X.dtype)
    Y, Y2, Y3, Y4, W = ws[0], ws[1], ws[2], ws[3], ws[4]
    for i in range(r):
        for j in range(r):
            Y[i, j] = X[i, j] * sc
    _matmul(Y, Y, Y2)
    _matmul(Y2, Y, Y3)
    _matmul(Y2, Y2, Y4)
    c = _INV_FACT
    for i in range(r):  # E = B_3 + c_16 Y^4, B_j = c_4j I + c_4j+1 Y + c_4j+2 Y^2 + c_4j+3 Y^3
        for j in range(r):
            E[i, j] = c[13] * Y[i, j] + c[14] * Y2[i, j] + c[15] * Y3[i, j] + c[16] * Y4[i, j]
        E[i, i] += c[12]
    for blk in range(2, -1, -1):  # E = B_blk + Y^4 E
        _matmul(Y4, E, W)
        k = 4 * blk
        for i in range(r):
            for j in range(r):
                E[i, j] = W[i, j] + c[k + 1] * Y[i, j] + c[k + 2] * Y2[i, j] + c[k + 3] * Y3[i, j]
            E[i, i] += c[k]
    for _ in range(s):
        _matmul(E, E, W)
        for i in range(r):
            for j in range(r):
                E[i, j] = W[i, j]


@njit(cache=True, nogil=True, inline="always")
def expm_frechet(X, Es, E, L):
    """``E = exp(X)`` and ``L[c] = L(X, Es[c])``, the Frechet derivatives of ``exp`` at ``X`` in the
    directions ``Es[c]`` (m, r, r): the blocks of ``exp([[X, Es[c]], [0, X]]) = [[E, L[c]], [0, E]]``
    (Higham, Functions of Matrices, 3.2), by scaling and squaring applied to that block matrix --
    the Taylor series of the block scaled by ``2^-s`` (``s`` from its 1-norm bound
    ``|X|_1 + max_c |Es[c]|_1``, down to 1/2) summed until its terms fall below ``1e-18``, then ``s``
    squarings -- written on the blocks: term ``k`` is ``[[T_k, U_k], [0, T_k]]`` with
    ``T_k = T_(k-1) X' / k``, ``U_k = (U_(k-1) X' + T_(k-1) E') / k``, and a squaring maps ``(E, L)``
    to ``(E^2, E L + L E)``; the same arithmetic without the zero block, and ``T_k`` shared by all
    directions (``2m + 1`` products of ``r x r`` matrices per term instead of ``m`` of ``2r x 2r``)."""
    m = Es.shape[0]
    r = X.shape[0]
    nrm = _norm1(X)
    ne = 0.0
    for c in range(m):
        ne = max(ne, _norm1(Es[c]))
    nrm += ne
    s = 0
    while nrm > 0.5:
        nrm *= 0.5
        s += 1
    sc = 0.5**s
    T = np.zeros((r, r))
    Tn = np.zeros((r, r))
    W = np.zeros((r, r))
    W2 = np.zeros((r, r))
    U = np.zeros((m, r, r))
    for i in range(r):
        for j in range(r):
            E[i, j] = 0.0
            T[i, j] = 0.0
            for c in range(m):
                L[c, i, j] = 0.0
                U[c, i, j] = 0.0
        E[i, i] = 1.0
        T[i, i] = 1.0
    # the products by _matmul on the leading-index views (C-contiguous 2-d: the one compiled
    # _matmul of expm; loops written out over the 3-d arrays cost compile time, issue 25)
    for k in range(1, 40):
        f = sc / k
        tmax = 0.0
        for c in range(m):  # U_k = (U_(k-1) X + T_(k-1) E_c) sc / k, from the old T
            Uc = U[c]
            _matmul(Uc, X, W)
            _matmul(T, Es[c], W2)
            Lc = L[c]
            for i in range(r):
                for j in range(r):
                    w = (W[i, j] + W2[i, j]) * f
                    Uc[i, j] = w
                    Lc[i, j] += w
                    tmax = max(tmax, abs(w))
        _matmul(T, X, Tn)
        for i in range(r):
            for j in range(r):
                T[i, j] = Tn[i, j] * f
                E[i, j] += T[i, j]
                tmax = max(tmax, abs(T[i, j]))
        if tmax <= 1e-18:
            break
    for _ in range(s):
        for c in range(m):  # L_c <- E L_c + L_c E
            Lc = L[c]
            _matmul(E, Lc, W)
            _matmul(Lc, E, W2)
            for i in range(r):
                for j in range(r):
                    Lc[i, j] = W[i, j] + W2[i, j]
        _matmul(E, E, W)
        for i in range(r):
            for j in range(r):
                E[i, j] = W[i, j]


@njit(cache=True, nogil=True)
def _inverse_det(A, Ainv, M):
    """``Ainv = A^-1`` by Gauss-Jordan with partial pivoting in the workspace ``M`` (r, 2r), returning
    ``|det A|`` (which may underflow to 0.0), or -1.0 when a pivot vanishes (``Ainv`` then not
    written). The one inverse of this
    module (the adjoint's, the logarithm's square roots and the refine's normal equations): each
    compiled helper costs its own compilation and is compiled again into every caller."""
    r = A.shape[0]
    for i in range(r):
        for j in range(r):
            M[i, j] = A[i, j]
            M[i, r + j] = 0.0
        M[i, r + i] = 1.0
    det = 1.0
    for c in range(r):
        p = c
        for i in range(c + 1, r):
            if abs(M[i, c]) > abs(M[p, c]):
                p = i
        if not (abs(M[p, c]) > 0.0):
            return -1.0
        if p != c:
            for j in range(2 * r):
                tmp = M[c, j]
                M[c, j] = M[p, j]
                M[p, j] = tmp
        det *= abs(M[c, c])
        piv = 1.0 / M[c, c]
        for j in range(2 * r):
            M[c, j] *= piv
        for i in range(r):
            if i != c:
                g = M[i, c]
                if g != 0.0:
                    for j in range(2 * r):
                        M[i, j] -= g * M[c, j]
    for i in range(r):
        for j in range(r):
            Ainv[i, j] = M[i, r + j]
    return det


LOG_SERIES_RADIUS = 0.5
""":func:`logm` takes square roots until ``|A - I|_1 <= LOG_SERIES_RADIUS``, then sums the series
``log A = 2 atanh(Z)``, ``Z = (A - I)(A + I)^-1`` (``|Z|_1 <= 0.5 / 1.5``: a term falls by ``1/9`` or
more, about 17 terms to ``1e-18``; at 0.2, the old radius, about 9, but one square root more, which
costs five to ten times a term). Each square root halves ``log A``: ``2^s`` multiplies what the series
and the roots leave, as in scipy's inverse scaling and squaring."""


@njit(cache=True, nogil=True)
def logm(G, L):
    """Principal logarithm: the finite series of a unipotent ``G``, else square roots until
    ``||G^(1/2^s) - 1||_1 <=`` :data:`LOG_SERIES_RADIUS`, then ``log A = 2 atanh(Z)``,
    ``Z = (A - 1)(A + 1)^-1`` (the series ``2 (Z + Z^3/3 + ...)``), times ``2^s``. False when a square
    root fails or more than 40 are needed. One workspace allocation per call.

    Unipotent ``G``: ``L = log G = sum_(k<r) (-1)^(k+1) N^k / k`` when ``N = G - I`` is nilpotent with
    ``N^r = 0`` exactly in floating point (``N`` strictly triangular in the representation's basis, as
    on nilpotent algebras: the products' zeros are structural); the series then is the logarithm
    itself, with no square roots.

    Square roots: the Denman-Beavers iteration ``Y_0 = A``, ``Z_0 = I``, ``Y <- (mu Y + Z^-1 / mu) / 2``,
    ``Z <- (mu Z + Y^-1 / mu) / 2`` with determinantal scaling ``mu = |det Y det Z|^(-1/(2r))`` (Higham,
    Functions of Matrices, 2008, 6.3 and 6.5; it only speeds up the first iterations and stops once an
    update moves ``Y`` by at most ``1e-2 |Y|``), until an update moves ``Y`` by at most ``1e-15 |Y|``
    (max norms) or follows one that moved it by at most ``1e-7 |Y|`` (convergence is quadratic: that
    one left ~1e-14, and on ill-conditioned ``A`` the moves then stall at ``~cond eps`` instead of
    reaching 1e-15, measured 1e-14 on ``exp`` of a Bianchi VI0 element of norm 8); a failure when it
    does not converge in 60 iterations or a pivot vanishes (an eigenvalue on or near the closed
    negative real axis).

    Both are written here rather than called (they were ``_log_unipotent`` and ``_sqrtm``): numba
    compiles each compiled callee on its own and again inside every caller, so each level of the
    first call's chain costs cold compile time (issue 25)."""
    r = G.shape[0]
    # workspace: r x r blocks as leading-index views of one C-contiguous array (C-contiguous
    # themselves, so the helpers compile for one array layout), and the inverse's r x 2r
    ws = np.zeros((13, r, r), dtype=G.dtype)
    inv_ws = np.zeros((r, 2 * r), dtype=G.dtype)
    A, B, M, Mi, W, Z, Z2, T, Ap, Api = (
        ws[0],
        ws[1],
        ws[2],
        ws[3],
        ws[4],
        ws[5],
        ws[6],
        ws[7],
        ws[8],
        ws[9],
    )
    for i in range(r):
        for j in range(r):
            A[i, j] = G[i, j]
    # the finite series of a unipotent G (the body of _log_unipotent, written here: one compiled
    # callee fewer in the first call's chain -- each @njit level recompiles its callees' code)
    N, P, W2 = ws[10], ws[11], ws[12]
    for i in range(r):
        for j in range(r):
            N[i, j] = G[i, j] - (1.0 if i == j else 0.0)
            P[i, j] = N[i, j]
            L[i, j] = 0.0
    for k in range(1, r + 1):  # P = N^k; after the loop's last product N^(r)
        zero = True
        for i in range(r):
            for j in range(r):
                if P[i, j] != 0.0:
                    zero = False
        if zero:
            return True
        if k == r:
            break
        c = (1.0 if k % 2 == 1 else -1.0) / k
        for i in range(r):
            for j in range(r):
                L[i, j] += c * P[i, j]
        _matmul(P, N, W2)
        for i in range(r):
            for j in range(r):
                P[i, j] = W2[i, j]
    s = 0
    while True:
        d = 0.0
        for j in range(r):
            c = 0.0
            for i in range(r):
                c += abs(A[i, j] - (1.0 if i == j else 0.0))
            d = max(d, c)
        if not math.isfinite(d):
            return False
        if d <= LOG_SERIES_RADIUS:
            break
        if s >= 40:
            return False
        # B = sqrt(A): the body of _sqrtm (its workspace Z = M, Yi = Mi, Zi = W, ws = inv_ws), written
        # here for the same reason
        for i in range(r):
            for j in range(r):
                B[i, j] = A[i, j]
                M[i, j] = 0.0
            M[i, i] = 1.0
        scale = True
        prev = np.inf
        root = False
        for _ in range(60):
            dy = _inverse_det(B, Mi, inv_ws)
            dz = _inverse_det(M, W, inv_ws)
            if not (dy > 0.0 and dz > 0.0):
                return False
            mu = (dy * dz) ** (-0.5 / r) if scale else 1.0
            if not (mu > 0.0 and math.isfinite(mu)):
                return False
            h = 0.5 * mu
            hi = 0.5 / mu
            dd = 0.0
            ny = 0.0
            for i in range(r):
                for j in range(r):
                    yn = h * B[i, j] + hi * W[i, j]
                    dd = max(dd, abs(yn - B[i, j]))
                    ny = max(ny, abs(yn))
                    B[i, j] = yn
                    M[i, j] = h * M[i, j] + hi * Mi[i, j]
            if not ny > 0.0:  # Y = 0 (A = -I: mu Y + Y^-1 / mu vanishes): no principal root
                return False
            if dd <= 1e-2 * ny:
                scale = False
            if dd <= 1e-15 * ny or prev <= 1e-7:
                root = True
                break
            prev = dd / ny
        if not root:
            return False
        for i in range(r):
            for j in range(r):
                A[i, j] = B[i, j]
        s += 1
    for i in range(r):
        for j in range(r):
            Ap[i, j] = A[i, j]
            A[i, j] = A[i, j] - (1.0 if i == j else 0.0)  # A - I from here on
        Ap[i, i] += 1.0
    if not (_inverse_det(Ap, Api, inv_ws) > 0.0):
        return False
    _matmul(A, Api, Z)
    _matmul(Z, Z, Z2)
    for i in range(r):
        for j in range(r):
            T[i, j] = Z[i, j]
            L[i, j] = Z[i, j]
    for k in range(1, 60):
        _matmul(T, Z2, W)
        tmax = 0.0
        for i in range(r):
            for j in range(r):
                T[i, j] = W[i, j]
                L[i, j] += W[i, j] / (2 * k + 1)
                tmax = max(tmax, abs(W[i, j]))
        if tmax <= 1e-18:
            break
    f = 2.0 * 2.0**s
    for i in range(r):
        for j in range(r):
            L[i, j] *= f
    return True


# ---------------------------------------------------------------------- the logarithm in closed form
# Small real representations (issue 25: on n = 3 the logarithm by square roots was half the pair's
# cost): rho real 2 x 2 (sl(2, R)), and rho real 3 x 3 with one row ``k`` zero in every rho(E_a)
# (the affine algebras R x| R^2 -- se(2), Bianchi II-VII, h(3) -- where exp(rho(x)) keeps row k at
# e_k: after moving k last, G = [[A, b], [0, 1]] and log G = [[log A, v], [0, 0]] with
# phi1(log A) v = b, phi1(z) = (e^z - 1)/z). The shape is read from the matrices (the
# representation), never from a value.


LOG_GENERAL = 0
""":func:`log_batch_exp`'s logarithm :func:`logm` (the ``kind`` of the log's compiled entries)."""
LOG_SMALL = 1
""":func:`log_small` (a representation of :func:`small_shape` other than :data:`SHAPE_GENERAL`)."""
LOG_SO4 = 2
""":func:`_log_so4` alone (a representation of :func:`small_shape` :data:`SHAPE_SO4`: neither the
2 x 2 nor the affine forms of :func:`log_small` compiled)."""
LOG_SO3 = 3
""":func:`_log_so3` alone (:func:`small_shape` :data:`SHAPE_SO3`)."""
SHAPE_GENERAL = -2
""":func:`small_shape` of a representation :func:`log_small` does not cover."""
SHAPE_SO4 = -3
""":func:`small_shape` of a real 4 x 4 representation by antisymmetric matrices (``G`` in SO(4))."""
SHAPE_SO3 = -4
""":func:`small_shape` of a real 3 x 3 representation by antisymmetric matrices (``G`` in SO(3))."""


@njit(cache=True, nogil=True)
def small_shape(mats, cplx):
    """:func:`log_small`'s shape of the representation ``mats`` (n, r, r): -1 real 2 x 2; ``k``
    (0..r-1) real 2 x 2 or 3 x 3 with row ``k`` of every ``rho(E_a)`` zero (affine); :data:`SHAPE_SO4` real 4 x 4 with
    every ``rho(E_a)`` antisymmetric; :data:`SHAPE_SO3` the same 3 x 3 (without a zero row);
    :data:`SHAPE_GENERAL` otherwise (:func:`logm`)."""
    n, r, _ = mats.shape
    if cplx:
        return -2
    if r == 2:
        for k in range(
            2
        ):  # affine 2 x 2 (aff(1)): the whole 2 x 2 form applies, k for the abelian one
            zero = True
            for a in range(n):
                for j in range(2):
                    if mats[a, k, j] != 0.0:
                        zero = False
            if zero:
                return k
        return -1
    if r == 4:
        for a in range(n):
            for i in range(4):
                for j in range(4):
                    if mats[a, i, j] != -mats[a, j, i]:
                        return -2
        return -3
    if r != 3:
        return -2
    for k in range(3):
        zero = True
        for a in range(n):
            for j in range(3):
                if mats[a, k, j] != 0.0:
                    zero = False
        if zero:
            return k
    for a in range(n):
        for i in range(3):
            for j in range(3):
                if mats[a, i, j] != -mats[a, j, i]:
                    return -2
    return -4


@njit(cache=True, nogil=True, inline="always")
def _block(r, k):
    """The rows/columns ``(i0, i1)`` of the 2 x 2 block: ``(0, 1)`` for ``r = 2``, else the two
    indices other than ``k``."""
    if r == 2:
        return 0, 1
    return (1 if k == 0 else 0), (1 if k == 2 else 2)


@njit(cache=True, nogil=True)
def _phi1(z):
    """``(e^z - 1) / z`` (1 at 0), by ``expm1``: accurate to a few ulp for every real ``z``."""
    return 1.0 if z == 0.0 else math.expm1(z) / z


@njit(cache=True, nogil=True)
def _phi1_pair(l0, delta):
    """``phi1(L) = f0 I + f1 N`` for ``L = l0 I + N``, ``N`` traceless with ``N^2 = delta I``: the
    Taylor series of ``L / 2^s`` (``|l0| + sqrt|delta|`` scaled to 1/2 or less) on the pairs, then
    ``phi1(2Y) = (e^Y + I) phi1(Y) / 2``, ``e^(2Y) = (e^Y)^2``. Returns ``(f0, f1)``."""
    nrm = abs(l0) + math.sqrt(abs(delta))
    s = 0
    while nrm > 0.5:
        nrm *= 0.5
        s += 1
    h = 0.5**s
    y0 = l0 * h  # Y = y0 I + h N
    y1 = h
    e0, e1 = 1.0, 0.0  # e^Y
    f0, f1 = 1.0, 0.0  # phi1(Y)
    t0, t1 = 1.0, 0.0  # Y^k / k!
    for k in range(1, 30):
        u0 = (t0 * y0 + t1 * y1 * delta) / k
        u1 = (t0 * y1 + t1 * y0) / k
        t0, t1 = u0, u1
        e0 += t0
        e1 += t1
        f0 += t0 / (k + 1)
        f1 += t1 / (k + 1)
        if abs(t0) + abs(t1) * math.sqrt(abs(delta)) <= 1e-18:
            break
    for _ in range(s):
        a0 = 0.5 * ((e0 + 1.0) * f0 + e1 * f1 * delta)
        a1 = 0.5 * ((e0 + 1.0) * f1 + e1 * f0)
        f0, f1 = a0, a1
        a0 = e0 * e0 + e1 * e1 * delta
        a1 = 2.0 * e0 * e1
        e0, e1 = a0, a1
    return f0, f1


@njit(cache=True, nogil=True)
def _solve_phi1(l0, p, q, c, bx, by):
    """``v`` with ``phi1(L) v = b`` for ``L = l0 I + N``, ``N = [[p, q], [c, -p]]`` (traceless, so
    ``N^2 = delta I``, ``delta = p^2 + q c``): every function of ``L`` is ``alpha I + beta N``.
    ``phi1(L)`` by scaling and squaring on those pairs (Taylor series of ``L / 2^s`` with
    ``|l0| + sqrt|delta|`` scaled to 1/2 or less, then ``phi1(2Y) = (e^Y + I) phi1(Y) / 2``,
    ``e^(2Y) = (e^Y)^2``), the inverse ``(alpha I - beta N) / det`` with ``det = alpha^2 - beta^2
    delta = phi1(l0 + t) phi1(l0 - t)`` (``t = sqrt(delta)``: that product when ``delta > 0``, where
    the difference cancels; a sum of squares when ``delta <= 0``); on the eigenvectors instead when
    ``t > 1/2`` (below). Returns ``(v0, v1, ok)``."""
    delta = p * p + q * c
    nrm = abs(l0) + math.sqrt(abs(delta))
    if not math.isfinite(nrm):
        return 0.0, 0.0, False
    nbx = p * bx + q * by
    nby = c * bx - p * by
    if delta > 0.25:
        # real eigenvalues l0 +- t, t > 1/2: on the eigenvectors, v = g(l0 + t) P+ b + g(l0 - t) P- b
        # (g = 1 / phi1 = z / expm1(z), P+- = (I +- N / t) / 2): each component to a few ulp, where
        # alpha -+ beta t cancel in the pairs' form (its residual phi1(L) v - b reached ~10 eps |b|)
        t = math.sqrt(delta)
        gp = 1.0 / _phi1(l0 + t)
        gm = 1.0 / _phi1(l0 - t)
        v0 = 0.5 * (gp * (bx + nbx / t) + gm * (bx - nbx / t))
        v1 = 0.5 * (gp * (by + nby / t) + gm * (by - nby / t))
        return v0, v1, math.isfinite(v0) and math.isfinite(v1)
    f0, f1 = _phi1_pair(l0, delta)
    if delta > 0.0:
        t = math.sqrt(delta)
        det = _phi1(l0 + t) * _phi1(l0 - t)
    else:
        det = f0 * f0 - f1 * f1 * delta  # a sum of squares
    v0 = (f0 * bx - f1 * nbx) / det
    v1 = (f0 * by - f1 * nby) / det
    return v0, v1, math.isfinite(v0) and math.isfinite(v1) and det > 0.0


# Quaternion multiplication as 4 x 4 matrices on (1, i, j, k): L(p) v = p v and R(q) v = v q, as
# sign tables: _QL[i, a, b] is the coefficient of p_i in L(p)[a, b], _QR likewise for q_j in R(q).
_QL = np.array([
    [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
    [[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 0, -1], [0, 0, 1, 0]],
    [[0, 0, -1, 0], [0, 0, 0, 1], [1, 0, 0, 0], [0, -1, 0, 0]],
    [[0, 0, 0, -1], [0, 0, -1, 0], [0, 1, 0, 0], [1, 0, 0, 0]],
], dtype=np.float64)  # fmt: skip
_QR = np.array([
    [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
    [[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1], [0, 0, -1, 0]],
    [[0, 0, -1, 0], [0, 0, 0, -1], [1, 0, 0, 0], [0, 1, 0, 0]],
    [[0, 0, 0, -1], [0, 0, 1, 0], [0, -1, 0, 0], [1, 0, 0, 0]],
], dtype=np.float64)  # fmt: skip
_QLR = np.ascontiguousarray(np.einsum("iam,jmb->ijab", _QL, _QR))  # L(e_i) R(e_j)


@njit(cache=True, nogil=True)
def _log_so4(G, L):
    """The principal logarithm of ``G`` in SO(4) (:data:`SHAPE_SO4`) through ``G = L(p) R(q)``, ``p``,
    ``q`` unit quaternions: ``p_i q_j = <L(e_i) R(e_j), G>_F / 4`` (the 16 products are orthogonal,
    each of squared norm 4), ``q`` the largest row of that rank-one matrix normalised, ``p`` the matrix
    times ``q``; angles ``alpha = atan2(|p_vec|, p_0)``, ``beta`` likewise in ``[0, pi]``, the sign of
    the pair ``(p, q) ~ (-p, -q)`` taken with ``alpha + beta < pi`` (``G``'s rotation angles are
    ``alpha +- beta``: the principal logarithm), then ``log G = L(alpha u_p) + R(beta u_q)`` (the two
    commute). False when ``alpha + beta = pi`` after that choice (an eigenvalue -1: no principal
    logarithm) or ``G`` is not finite."""
    M = np.empty((4, 4))
    for i in range(4):
        for j in range(4):
            acc = 0.0
            for a in range(4):
                for b in range(4):
                    acc += _QLR[i, j, a, b] * G[a, b].real
            M[i, j] = 0.25 * acc
    ib = 0
    best = -1.0
    for i in range(4):
        nr = M[i, 0] ** 2 + M[i, 1] ** 2 + M[i, 2] ** 2 + M[i, 3] ** 2
        if nr > best:
            best = nr
            ib = i
    if not (best > 0.0 and math.isfinite(best)):
        return False
    nq = math.sqrt(best)
    q = np.empty(4)
    pq = np.empty(4)
    for j in range(4):
        q[j] = M[ib, j] / nq
    for i in range(4):
        pq[i] = M[i, 0] * q[0] + M[i, 1] * q[1] + M[i, 2] * q[2] + M[i, 3] * q[3]
    npq = math.sqrt(pq[0] ** 2 + pq[1] ** 2 + pq[2] ** 2 + pq[3] ** 2)
    for i in range(4):
        pq[i] /= npq
    sp = math.sqrt(pq[1] ** 2 + pq[2] ** 2 + pq[3] ** 2)
    sq = math.sqrt(q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    alpha = math.atan2(sp, pq[0])
    beta = math.atan2(sq, q[0])
    if alpha + beta > math.pi:  # the other sign of the pair: angles pi - alpha, pi - beta
        for i in range(4):
            pq[i] = -pq[i]
            q[i] = -q[i]
        alpha = math.atan2(sp, pq[0])
        beta = math.atan2(sq, q[0])
    if not alpha + beta < math.pi:
        return False
    fp = alpha / sp if sp > 0.0 else 1.0  # log p = (alpha / |p_vec|) p_vec
    fq = beta / sq if sq > 0.0 else 1.0
    for a in range(4):
        for b in range(4):
            acc = 0.0
            for i in range(1, 4):
                acc += fp * pq[i] * _QL[i, a, b] + fq * q[i] * _QR[i, a, b]
            L[a, b] = acc
    return True


@njit(cache=True, nogil=True)
def _log_so3(G, L):
    """The principal logarithm of ``G`` in SO(3) (:data:`SHAPE_SO3`) by Rodrigues' formula:
    ``A = (G - G^T) / 2 = sin(theta) K``, ``theta = atan2(|a|, (tr G - 1) / 2)`` in ``[0, pi)`` (``a``
    the axial vector of ``A``), ``log G = (theta / sin theta) A`` (the factor 1 at ``theta = 0``).
    False at ``theta = pi`` (``A = 0`` with ``tr G < 1``: an eigenvalue -1, no principal logarithm)
    or when ``G`` is not finite."""
    a0 = 0.5 * (G[2, 1].real - G[1, 2].real)
    a1 = 0.5 * (G[0, 2].real - G[2, 0].real)
    a2 = 0.5 * (G[1, 0].real - G[0, 1].real)
    sn = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    cs = 0.5 * (G[0, 0].real + G[1, 1].real + G[2, 2].real - 1.0)
    if not (math.isfinite(sn) and math.isfinite(cs)):
        return False
    if sn > 0.0:
        f = math.atan2(sn, cs) / sn
    elif cs > 0.0:
        f = 1.0
    else:
        return False
    for i in range(3):
        for j in range(3):
            L[i, j] = f * 0.5 * (G[i, j].real - G[j, i].real)
    return True


@njit(cache=True, nogil=True)
def log_small(G, L, k):
    """The principal logarithm ``L`` of ``G`` in closed form for :func:`small_shape` ``k`` (-1: 2 x 2;
    0..2: 3 x 3 with row ``k`` of ``G`` equal to ``e_k``; :data:`SHAPE_SO4`: :func:`_log_so4`;
    :data:`SHAPE_SO3`: :func:`_log_so3`). False
    where :func:`logm` has none either: a block ``A`` with ``det A <= 0`` or a negative eigenvalue.

    ``A = e^l0 C``, ``l0 = log(det A) / 2``, ``det C = 1``; ``C = c I + M``, ``c = tr C / 2``, ``M``
    traceless with ``M^2 = -det(M) I``: ``log C = (theta / sinh theta) M``, ``theta = asinh(sqrt(-det
    M))``, when ``det M < 0`` (hyperbolic; ``c > 0`` needed, else the eigenvalues are negative);
    ``(theta / sin theta) M``, ``theta = atan2(sqrt(det M), c)`` in ``(0, pi)``, when ``det M > 0``
    (elliptic); ``M`` itself when ``det M = 0`` (parabolic, ``c > 0``). ``theta`` is read from
    ``sqrt|det M|``, never from ``c`` (no cancellation near the parabolic case, where the factor tends
    to 1). The 3 x 3 case then solves ``phi1(log A) v = b`` (:func:`_solve_phi1`)."""
    if k == SHAPE_SO4:
        return _log_so4(G, L)
    if k == SHAPE_SO3:
        return _log_so3(G, L)
    r = G.shape[0]
    i0, i1 = _block(r, k)
    a = G[i0, i0].real
    b = G[i0, i1].real
    c = G[i1, i0].real
    d = G[i1, i1].real
    det = a * d - b * c
    if not (det > 0.0 and math.isfinite(det)):
        return False
    l0 = 0.5 * math.log(det)
    e = 1.0 / math.sqrt(det)
    tc = 0.5 * (a + d) * e
    p = 0.5 * (a - d) * e
    q = b * e
    cc = c * e
    dm = -(p * p) - q * cc  # det M
    if dm < 0.0:
        if not tc > 0.0:
            return False
        sh = math.sqrt(-dm)
        f = math.asinh(sh) / sh
    elif dm > 0.0:
        sn = math.sqrt(dm)
        f = math.atan2(sn, tc) / sn
    else:
        if not tc > 0.0:
            return False
        f = 1.0
    for i in range(r):
        for j in range(r):
            L[i, j] = 0.0
    L[i0, i0] = l0 + f * p
    L[i0, i1] = f * q
    L[i1, i0] = f * cc
    L[i1, i1] = l0 - f * p
    if r == 2:
        return True
    v0, v1, good = _solve_phi1(l0, f * p, f * q, f * cc, G[i0, k].real, G[i1, k].real)
    L[i0, k] = v0
    L[i1, k] = v1
    return good


@njit(cache=True, nogil=True)
def derived_in_translations(Dr, k):
    """Whether ``rho([g, g])`` (``Dr``, (m, r, r): ``rho`` of its basis) lies in the translations of
    the :func:`small_shape` ``k >= 0`` representation: ``m < r`` and no ``rho(D_c)`` has a block
    (to ``1e-12`` of its size: ``D`` comes from an SVD). Then the block of ``rho(x)`` depends on
    ``x``'s abelian part alone (:func:`log_from_abelian`)."""
    r = Dr.shape[1]
    if Dr.shape[0] > r - 1 or r not in (2, 3):
        return False
    if r == 2:  # the 1 x 1 block
        i0 = i1 = 1 - k
    else:
        i0 = 1 if k == 0 else 0  # _block(3, k), written out: pair_log_for runs this in Python
        i1 = 1 if k == 2 else 2
    for c in range(Dr.shape[0]):
        big = 0.0
        for i in range(r):
            for j in range(r):
                big = max(big, abs(Dr[c, i, j]))
        for i in (i0, i1):
            for j in (i0, i1):
                if abs(Dr[c, i, j]) > 1e-12 * big:
                    return False
    return True


@njit(cache=True, nogil=True)
def log_from_abelian(s, Ppinv, Dr, mats, k, G, L):
    """The logarithm ``L`` of ``G`` with the abelian part ``s`` (``P x = s``) on a representation where
    :func:`derived_in_translations`: ``x = pinv(P) s + D w``, the block ``log A`` of ``rho(x)`` is that
    of ``rho(pinv(P) s)`` (``rho(D w)`` has none) and its translation is ``u = u0 + T w`` (``u0``
    that of ``rho(pinv(P) s)``, ``T`` those of ``rho(D)``); ``w`` minimises ``|phi1(log A) u - b|``,
    which is all of ``|exp(rho(x)) - G|`` that ``w`` moves -- the minimiser :func:`refine_abelian`
    approaches by Gauss-Newton, in closed form: ``u = phi1(log A)^-1 b`` (:func:`_solve_phi1`) when
    ``[g, g]`` is both translations (``m = 2``), the one-dimensional least squares
    ``w = <Phi t, b - Phi u0> / |Phi t|^2`` when ``m = 1`` (Bianchi II, III, h(3)). False when ``u`` is
    not finite."""
    n = mats.shape[0]
    m = Dr.shape[0]
    if mats.shape[1] == 2:  # aff(1): G = [[e^l, phi1(l) u], [0, 1]] (k = 1; k = 0 transposed)
        j0 = 1 - k
        lb = 0.0
        u = 0.0
        for a in range(n):
            xa = 0.0
            for ell in range(s.shape[0]):
                xa += Ppinv[a, ell] * s[ell]
            lb += xa * mats[a, j0, j0]
            u += xa * mats[a, j0, k]
        if m == 1:  # the translation free: u = b / phi1(l), the exact fit
            u = G[j0, k].real / _phi1(lb)
        L[k, 0] = 0.0
        L[k, 1] = 0.0
        L[j0, j0] = lb
        L[j0, k] = u
        return math.isfinite(u)
    i0, i1 = _block(3, k)
    t00 = 0.0
    t01 = 0.0
    t10 = 0.0
    t11 = 0.0
    u0 = 0.0
    u1 = 0.0
    for a in range(n):
        xa = 0.0
        for ell in range(s.shape[0]):
            xa += Ppinv[a, ell] * s[ell]
        t00 += xa * mats[a, i0, i0]
        t01 += xa * mats[a, i0, i1]
        t10 += xa * mats[a, i1, i0]
        t11 += xa * mats[a, i1, i1]
        u0 += xa * mats[a, i0, k]
        u1 += xa * mats[a, i1, k]
    l0 = 0.5 * (t00 + t11)
    p = 0.5 * (t00 - t11)
    bx = G[i0, k].real
    by = G[i1, k].real
    if m == 2:
        v0, v1, good = _solve_phi1(l0, p, t01, t10, bx, by)
    else:
        f0, f1 = _phi1_pair(l0, p * p + t01 * t10)
        # Phi y = f0 y + f1 N y, N = [[p, t01], [t10, -p]]
        pu0 = f0 * u0 + f1 * (p * u0 + t01 * u1)
        pu1 = f0 * u1 + f1 * (t10 * u0 - p * u1)
        v0, v1 = u0, u1
        if m == 1:
            c0 = Dr[0, i0, k]
            c1 = Dr[0, i1, k]
            pt0 = f0 * c0 + f1 * (p * c0 + t01 * c1)
            pt1 = f0 * c1 + f1 * (t10 * c0 - p * c1)
            den = pt0 * pt0 + pt1 * pt1
            if not den > 0.0:  # (numba raises on a division by zero)
                return False
            w = (pt0 * (bx - pu0) + pt1 * (by - pu1)) / den
            v0 = u0 + w * c0
            v1 = u1 + w * c1
        good = math.isfinite(v0) and math.isfinite(v1)
    for i in range(3):
        for j in range(3):
            L[i, j] = 0.0
    L[i0, i0] = t00
    L[i0, i1] = t01
    L[i1, i0] = t10
    L[i1, i1] = t11
    L[i0, k] = v0
    L[i1, k] = v1
    return good


@njit(cache=True, nogil=True)
def _project(X, proj, cplx, out):
    """``out = proj @ vec(X)`` (real parts, then imaginary parts when ``cplx``)."""
    r = X.shape[0]
    n = proj.shape[0]
    for a in range(n):
        acc = 0.0
        for i in range(r):
            for j in range(r):
                acc += proj[a, i * r + j] * X[i, j].real
                if cplx:
                    acc += proj[a, r * r + i * r + j] * X[i, j].imag
        out[a] = acc


@njit(cache=True, nogil=True, inline="always")
def _exp_rho(v, mats, X, E):
    """``E = exp(rho(v))``, ``X`` receiving ``rho(v) = v^a mats[a]`` (summed in ``mats``' type, in
    the order of ``a``): the one place every exponential of a coordinate vector is formed."""
    n, r, _ = mats.shape
    for i in range(r):
        for j in range(r):
            acc = 0.0 * mats[0, i, j]
            for a in range(n):
                acc += v[a] * mats[a, i, j]
            X[i, j] = acc
    expm(X, E)


@njit(cache=True, nogil=True, inline="always")
def exp_batch(x, mats, out):
    """``out[N] = exp(rho(x[N]))``, ``rho(x) = x^a mats[a]``."""
    N = x.shape[0]
    r = mats.shape[1]
    X = np.zeros((r, r), dtype=mats.dtype)
    E = np.zeros((r, r), dtype=mats.dtype)
    for it in range(N):
        _exp_rho(x[it], mats, X, E)
        for i in range(r):
            for j in range(r):
                out[it, i, j] = E[i, j]


@njit(cache=True, nogil=True)
def ad_batch(G, mats, proj, cplx, out):
    """``out[N] = Ad(g)``: ``G E_b G^-1 = Ad_ab E_a`` projected on the ``E_a``; NaN when G is singular."""
    N, r, _ = G.shape
    n = mats.shape[0]
    Gi = np.zeros((r, r), dtype=G.dtype)
    W = np.zeros((r, r), dtype=G.dtype)
    X = np.zeros((r, r), dtype=G.dtype)
    ws = np.zeros((r, 2 * r), dtype=G.dtype)
    col = np.zeros(n)
    for it in range(N):
        Gt = G[it]
        if _inverse_det(Gt, Gi, ws) < 0.0:
            for a in range(n):
                for b in range(n):
                    out[it, a, b] = np.nan
            continue
        for b in range(n):
            _matmul(Gt, mats[b], W)
            _matmul(W, Gi, X)
            _project(X, proj, cplx, col)
            for a in range(n):
                out[it, a, b] = col[a]


def ad_table(mats, proj):
    """``(adt, adc)``: the sparsity of ``E_b = mats[b]`` and of ``proj`` for :func:`ad_sparse`, built
    once per representation (numpy). ``adt`` (int64): ``[Q, offset of the entries, then per b: the
    count and the ``(k, l)`` of the nonzero ``E_b[k, l]`` (row-major), the count and the indices of
    its nonzero columns (ascending); then the ``Q`` entries ``(i, j)`` that ``proj`` reads
    (row-major), each with the count and the rows ``a`` of its nonzero real-part coefficients, then
    of its imaginary-part ones]``; ``adc`` (``mats``' dtype): those ``E_b[k, l]``, then the
    coefficients of ``proj`` (real numbers) in the same order. On a dense basis (no zero entries) it
    lists every entry: the dense route's products, read through the tables."""
    mats = np.asarray(mats)
    proj = np.asarray(proj)
    n, r, _ = mats.shape
    rr = r * r
    cplx = np.iscomplexobj(mats)
    adt, ev = [0, 0], []
    for b in range(n):
        nz = [(k, l) for k in range(r) for l in range(r) if mats[b, k, l] != 0]
        cols = sorted({l for _, l in nz})
        adt += [len(nz)] + [v for kl in nz for v in kl] + [len(cols)] + cols
        ev += [mats[b, k, l] for k, l in nz]
    adt[1] = len(adt)
    pv = []
    for q in range(rr):
        re = [a for a in range(n) if proj[a, q] != 0]
        im = [a for a in range(n) if cplx and proj[a, rr + q] != 0]
        if re or im:
            adt[0] += 1
            adt += [q // r, q % r, len(re)] + re + [len(im)] + im
            pv += [proj[a, q] for a in re] + [proj[a, rr + q] for a in im]
    if any(not np.any(mats[b]) for b in range(n)):
        raise ValueError("ad_table: a basis element of the representation is zero (not faithful)")
    return np.array(adt, dtype=np.int64), np.array(ev + pv, dtype=mats.dtype)


@njit(cache=True, nogil=True, inline="always")
def _ad_proj_start(adt, n):
    """The index in ``adc`` of :func:`ad_table`'s first ``proj`` coefficient (after every ``E_b``)."""
    pos = 2
    t = 0
    for _ in range(n):
        t += adt[pos]
        pos += 1 + 2 * adt[pos]
        pos += 1 + adt[pos]
    return t


AD_NO_OVERFLOW = 1e300
""":func:`ad_sparse` gives NaN where ``r^2 max|G| max|E_b| max|G^-1|`` reaches this (``kappa(G)``
near 1e300: ``Ad(g)`` then has no correct digit in float64): below it no entry of ``G E_b`` or of
``G E_b G^-1`` can overflow, so the entries it skips (those ``proj`` does not read) are finite, as
their exact-zero contributions to the dense route's sums."""


@njit(cache=True, nogil=True)
def ad_sparse(G, adt, adc, out):
    """:func:`ad_batch` over the nonzero entries of :func:`ad_table`: ``out[N] =
    Ad(g)``, ``W = G E_b`` over the nonzero ``E_b[k, l]``, ``X = W G^-1`` at the entries ``proj``
    reads over the nonzero columns of ``W``, projected over the nonzero coefficients of ``proj`` --
    the dense route's sums, in its order (``G E_b`` first: on an ill-conditioned ``G`` that order
    keeps ``Ad`` accurate, where summing the products ``G_ik G^-1_lj`` did not), without its terms
    that are exact zeros: bitwise the dense route's ``Ad`` wherever ``G`` and ``G^-1`` are finite
    (and :data:`AD_NO_OVERFLOW`). NaN where ``G`` is not finite, singular, ``G^-1`` not finite, or
    past :data:`AD_NO_OVERFLOW` (the dense route: NaN, or an ``Ad`` without a correct digit)."""
    N, r, _ = G.shape
    n = out.shape[1]
    Gi = np.empty((r, r), dtype=G.dtype)
    W = np.zeros((r, r), dtype=G.dtype)
    ws = np.empty((r, 2 * r), dtype=G.dtype)
    emax = 0.0
    pstart = _ad_proj_start(adt, n)  # the first proj coefficient in adc
    pos = 2
    t = 0
    for b in range(n):  # the largest |E_b[k, l]|
        ne = adt[pos]
        for _ in range(ne):
            emax = max(emax, abs(adc[t]))
            t += 1
        pos += 1 + 2 * ne
        pos += 1 + adt[pos]
    for it in range(N):
        Gt = G[it]
        o = out[it]
        chk = 0.0  # 0.0 * v is NaN iff v is not finite
        gmax = 0.0
        for i in range(r):
            for j in range(r):
                z = Gt[i, j]
                chk += 0.0 * (z.real + z.imag)
                gmax = max(gmax, abs(z))
        good = chk == 0.0 and _inverse_det(Gt, Gi, ws) >= 0.0
        gimax = 0.0
        if good:
            for i in range(r):
                for j in range(r):
                    z = Gi[i, j]
                    chk += 0.0 * (z.real + z.imag)
                    gimax = max(gimax, abs(z))
            good = chk == 0.0 and r * r * gmax * emax * gimax < AD_NO_OVERFLOW
        if not good:
            for a in range(n):
                for b in range(n):
                    o[a, b] = np.nan
            continue
        pos = 2
        t = 0
        for b in range(n):
            ne = adt[pos]
            pe = pos + 1
            te = t
            pos += 1 + 2 * ne
            nc = adt[pos]
            pc = pos + 1
            pos += 1 + nc
            t += ne
            for c in range(nc):  # W = G E_b (its nonzero columns; _matmul's order over k)
                l = adt[pc + c]
                for i in range(r):
                    W[i, l] = 0.0
            for e in range(ne):
                k = adt[pe + 2 * e]
                l = adt[pe + 2 * e + 1]
                v = adc[te + e]
                for i in range(r):
                    W[i, l] += Gt[i, k] * v
            for a in range(n):
                o[a, b] = 0.0
            qp = adt[1]
            tp = pstart
            for _ in range(adt[0]):  # X[i, j] = sum over W's nonzero columns, then projected
                i = adt[qp]
                j = adt[qp + 1]
                x = W[i, adt[pc]] * Gi[adt[pc], j]
                for c in range(1, nc):
                    l = adt[pc + c]
                    x += W[i, l] * Gi[l, j]
                nre = adt[qp + 2]
                for m in range(nre):
                    o[adt[qp + 3 + m], b] += adc[tp + m].real * x.real
                qp += 3 + nre
                tp += nre
                nim = adt[qp]
                for m in range(nim):
                    o[adt[qp + 1 + m], b] += adc[tp + m].real * x.imag
                qp += 1 + nim
                tp += nim


@njit(cache=True, nogil=True)
def log_batch(G, mats, proj, cplx, out, ok):
    """``out[N]``: the coordinates of the principal logarithm of ``G[N]`` on the ``E_a``; ``ok[N]``
    when it exists and ``exp(rho(x)) = G`` to ``1e3 eps cond max(1, |G|) r`` (``cond = exp(||rho(x)||_1)``,
    the acceptance test of Representation._accept). The logarithm :func:`log_small` where
    :func:`small_shape` applies, else :func:`logm` (chosen at run time: this entry compiles both)."""
    if small_shape(mats, cplx) != SHAPE_GENERAL:
        log_batch_exp(G, mats, proj, cplx, out, ok, np.empty_like(G), LOG_SMALL)
    else:
        log_batch_exp(G, mats, proj, cplx, out, ok, np.empty_like(G), LOG_GENERAL)


@njit(cache=True, nogil=True, inline="always")
def log_batch_exp(G, mats, proj, cplx, out, ok, Ex, kind):
    """:func:`log_batch` by the logarithm ``kind`` (:data:`LOG_SMALL`: :func:`log_small`,
    :data:`LOG_SO4`: :func:`_log_so4`, :data:`LOG_SO3`: :func:`_log_so3`, else :func:`logm`; a constant at every call site, so numba prunes the other and never compiles it), keeping ``Ex[N] = exp(rho(x))`` of the acceptance test (what
    :func:`log_residual` computes again from ``x``: the same arithmetic) for the rows reaching it."""
    N, r, _ = G.shape
    n = mats.shape[0]
    L = np.zeros((r, r), dtype=G.dtype)
    X = np.zeros((r, r), dtype=G.dtype)
    x = np.zeros(n)
    shape = small_shape(mats, cplx) if kind == LOG_SMALL else -2
    for it in range(N):
        ok[it] = False
        Gt = G[it]
        E = Ex[it]
        if kind == LOG_SO4:
            found = _log_so4(Gt, L)
        elif kind == LOG_SO3:
            found = _log_so3(Gt, L)
        elif kind == LOG_SMALL:
            found = log_small(Gt, L, shape)
        else:
            found = logm(Gt, L)
        if not found:
            continue
        ok[it] = _accept_log(L, Gt, mats, proj, cplx, x, X, E, out[it])


@njit(cache=True, nogil=True, inline="always")
def _accept_log(L, Gt, mats, proj, cplx, x, X, E, out):
    """``out = x``, the coordinates of the logarithm ``L`` of ``Gt``, ``E = exp(rho(x))``; whether
    ``x`` is finite and ``exp(rho(x)) = Gt`` to ``1e3 eps cond max(1, |Gt|) r`` (``cond =
    exp(||rho(x)||_1)``, the acceptance test of Representation._accept)."""
    r = Gt.shape[0]
    n = x.shape[0]
    eps = 2.220446049250313e-16
    _project(L, proj, cplx, x)
    _exp_rho(x, mats, X, E)
    err = 0.0
    gmax = 0.0
    chk = 0.0  # 0.0 * v is NaN iff v is not finite: max() would drop a NaN
    for i in range(r):
        for j in range(r):
            v = abs(E[i, j] - Gt[i, j])
            err = max(err, v)
            gmax = max(gmax, abs(Gt[i, j]))
            chk += 0.0 * v
    cond = math.exp(min(50.0, _norm1(X)))
    good = chk == 0.0 and err <= 1e3 * eps * cond * max(1.0, gmax) * r
    for a in range(n):
        out[a] = x[a]
        if not math.isfinite(x[a]):
            good = False
    return good


@njit(cache=True, nogil=True, inline="always")
def pack_G(G, gpart, gi, gj, off, y):
    """``y[:, off + v] = Re/Im G[:, gi[v], gj[v]]`` (``gpart[v]`` 0 real, 1 imaginary)."""
    for it in range(G.shape[0]):
        for v in range(gpart.shape[0]):
            z = G[it, gi[v], gj[v]]
            y[it, off + v] = z.real if gpart[v] == 0 else z.imag


@njit(cache=True, nogil=True)
def unpack_G(y, gpart, gi, gj, off, G, unit):
    """The inverse of :func:`pack_G` (entries outside the pattern zero); ``unit``: ``1j`` for a complex
    ``G`` (0.0 for a real one, whose entries are all real parts)."""
    N, r, _ = G.shape
    for it in range(N):
        for i in range(r):
            for j in range(r):
                G[it, i, j] = 0.0
        for v in range(gpart.shape[0]):
            if gpart[v] == 0:
                G[it, gi[v], gj[v]] += y[it, off + v]
            else:
                G[it, gi[v], gj[v]] += unit * y[it, off + v]


@njit(cache=True, nogil=True, inline="always")
def estimate(A, B, n, gpart, gi, gj, off, unit, mats, proj, adt, adc, cplx, GB, AdB, est, size):
    """Per row: ``est = max(|pi_A - pi_B|, |Ad(g_A) - Ad(g_B)|)`` (inf when not finite); ``GB``, ``AdB``
    the group element and ``Ad`` of ``B``; ``size = max(|pi_B|, |Ad(g_B)|)``."""
    N = A.shape[0]
    r = mats.shape[1]
    GA = np.zeros((N, r, r), dtype=mats.dtype)
    AdA = np.zeros((N, n, n))
    unpack_G(A, gpart, gi, gj, off, GA, unit)
    unpack_G(B, gpart, gi, gj, off, GB, unit)
    ad_sparse(GA, adt, adc, AdA)
    ad_sparse(GB, adt, adc, AdB)
    for it in range(N):
        m = 0.0
        chk = 0.0  # 0.0 * v is NaN iff v is not finite: max() would drop a NaN
        for a in range(n):
            v = abs(A[it, a] - B[it, a])
            m = max(m, v)
            chk += 0.0 * v
        z = 0.0
        for a in range(n):
            z = max(z, abs(B[it, a]))
            chk += 0.0 * B[it, a]
            for b in range(n):
                v = abs(AdA[it, a, b] - AdB[it, a, b])
                m = max(m, v)
                z = max(z, abs(AdB[it, a, b]))
                chk += 0.0 * v + 0.0 * AdB[it, a, b]
        fin = chk == 0.0 and math.isfinite(m)
        est[it] = m if fin else np.inf
        size[it] = z if fin else np.inf


# ---------------------------------------------------------------------- the abelian part of the log
LOG_REFINE_FLOOR = 8.0 * 2.220446049250313e-16
"""Per unit of ``r max(1, |G|)``: the residual ``max |exp(rho(x)) - G|`` of the logarithm above which
:func:`log_state_refined` refines a row (:func:`refine_abelian`, which stops at the same floor: the
rounding of ``exp(rho(x))`` itself)."""


@njit(cache=True, nogil=True, inline="always")
def _resid(v, mats, G, X, E, R):
    """``R = exp(rho(v)) - G`` (``X`` receives ``rho(v)``); returns ``max |R|`` (inf when not finite)."""
    r = mats.shape[1]
    _exp_rho(v, mats, X, E)
    m = 0.0
    chk = 0.0
    for i in range(r):
        for j in range(r):
            R[i, j] = E[i, j] - G[i, j]
            m = max(m, abs(R[i, j]))
            chk += 0.0 * R[i, j]
    return m if chk == 0.0 and math.isfinite(m) else np.inf


@njit(cache=True, nogil=True)
def refine_abelian(G, x0, s, P, Ppinv, D, Dr, mats, out):
    """The compiled twin of :meth:`refimpl.flows._common._AbelianPart.refine` for a real representation
    (the same steps): ``out`` = ``x`` with ``P x = s`` and ``exp(rho(x))`` closest to ``G``, by at most
    eight Gauss-Newton steps over ``[g, g]`` (directions ``D``, their images ``Dr = D^T rho``; each
    step by the normal equations, not scipy's least squares) from
    ``x0 + pinv(P) (s - P x0)``, each kept only when it lowers ``max |exp(rho(x)) - G|``, none once that
    residual is at ``8 r eps max(1, |G|)`` (the rounding of ``exp(rho(x))``: no step can improve it,
    and one that tried cost another four exponentials); the Jacobian's
    columns are the Frechet derivatives ``L(rho(x), Dr_j)``, the upper right block of the exponential of
    ``[[rho(x), Dr_j], [0, rho(x)]]`` (Higham, Functions of Matrices, 3.2; all ``j`` in one call of
    :func:`expm_frechet`, on the blocks); ``x0`` itself when the fit
    does not come within ``10 |exp(rho(x0)) - G| + 1e3 eps max(1, |G|)``."""
    n = x0.shape[0]
    r = G.shape[0]
    m = Dr.shape[0]
    # workspaces as leading-index views of one array each (C-contiguous: the helpers' one layout;
    # each allocation site costs compile time)
    ws = np.zeros((6, r, r))
    X, E, R0, Rb, Rc, EZ = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5]
    Lc = np.zeros((m, r, r))
    wm = np.zeros((2, m, m))
    JtJ, JtJi = wm[0], wm[1]
    inv_ws = np.zeros((m, 2 * m))
    wv = np.zeros((2, m))
    Jr, dw = wv[0], wv[1]
    k = P.shape[0]
    ds = np.zeros(k)
    for ell in range(k):
        acc = s[ell]
        for a in range(n):
            acc -= P[ell, a] * x0[a]
        ds[ell] = acc
    best = np.zeros(n)
    for a in range(n):
        acc = x0[a]
        for ell in range(k):
            acc += Ppinv[a, ell] * ds[ell]
        best[a] = acc
    cand = np.zeros(n)
    r0 = _resid(x0, mats, G, X, E, R0)
    gmax = 0.0
    for i in range(r):
        for j in range(r):
            gmax = max(gmax, abs(G[i, j]))
    at_floor = LOG_REFINE_FLOOR * r * max(1.0, gmax)
    rb = _resid(best, mats, G, X, E, Rb)  # X = rho(best) from here on (the last _resid kept)
    for _ in range(8):
        if (
            rb <= at_floor
        ):  # a residual at the rounding of exp(rho(x)) itself: no step can improve it
            break
        expm_frechet(X, Dr, EZ, Lc)
        # the least-squares step by the normal equations (the small m x m Gauss-Jordan of _inverse_det:
        # no LAPACK binding to compile); the step's own error is corrected by the next iteration, and
        # a step that does not lower the residual is never taken. The Jacobian's column c is Lc[c]
        # read row by row (J[i r + j, c] = Lc[c, i, j]), the right-hand side -Rb likewise
        for a in range(m):
            acc = 0.0
            for i in range(r):
                for j in range(r):
                    acc += Lc[a, i, j] * -Rb[i, j]
            Jr[a] = acc
            for c in range(m):
                acc = 0.0
                for i in range(r):
                    for j in range(r):
                        acc += Lc[a, i, j] * Lc[c, i, j]
                JtJ[a, c] = acc
        fin = 0.0  # finite iff every entry is (a loop: np.all(np.isfinite()) compiles two ufuncs)
        for a in range(m):
            fin += 0.0 * Jr[a]
            for c in range(m):
                fin += 0.0 * JtJ[a, c]
        if not (fin == 0.0 and _inverse_det(JtJ, JtJi, inv_ws) >= 0.0):
            break
        for a in range(m):
            acc = 0.0
            for c in range(m):
                acc += JtJi[a, c] * Jr[c]
            dw[a] = acc
        for a in range(n):
            acc = best[a]
            for c in range(m):
                acc += D[a, c] * dw[c]
            cand[a] = acc
        rc = _resid(cand, mats, G, X, E, Rc)
        if not rc < rb:
            break
        rb = rc
        for a in range(n):
            best[a] = cand[a]
        for i in range(r):
            for j in range(r):
                Rb[i, j] = Rc[i, j]
    ok = rb <= r0 * 10 + 1e3 * 2.220446049250313e-16 * max(1.0, gmax)
    for a in range(n):
        out[a] = best[a] if ok else x0[a]


@njit(cache=True, nogil=True)
def abelian_batch(G, xs, s, P, Ppinv, D, Dr, mats, rtol):
    """Per row ``j`` of ``xs`` (N, n): when ``max |P xs[j] - s[:, j]| > rtol max(1, max |s[:, j]|)``,
    ``xs[j]`` is replaced by :func:`refine_abelian` (in place)."""
    N, n = xs.shape
    k = P.shape[0]
    out = np.zeros(n)
    for j in range(N):
        dev = 0.0
        smax = 0.0
        for ell in range(k):
            acc = 0.0
            for a in range(n):
                acc += P[ell, a] * xs[j, a]
            dev = max(dev, abs(acc - s[ell, j]))
            smax = max(smax, abs(s[ell, j]))
        if dev > rtol * max(1.0, smax):
            refine_abelian(G[j], xs[j].copy(), s[:, j].copy(), P, Ppinv, D, Dr, mats, out)
            for a in range(n):
                xs[j, a] = out[a]


# ---------------------------------------------------------------------- per-call glue, one call each
# The intermediate levels of the first call's chain (estimate, log_state[_refined], log_batch_exp,
# _residual_final, exp_batch, pack_G) are ``inline="always"``: numba inlines their IR into
# the caller instead of compiling each on its own and then linking and re-optimizing its whole call
# tree again into every caller above it (pair_log -> log_state -> log_batch_exp -> logm compiled the
# logarithm four times). Called from Python they still compile on their own. Measured fully cold
# (empty NUMBA_CACHE_DIR and TSTARG_CACHE_DIR, numba's compile events per function, se(3) first call, CPU):
# pair_log 7.29 -> 4.58 s, start 3.82 -> 3.23 s, the whole call 13.50 -> 10.37 s (load 3.0-4.0);
# warm flow calls unchanged (se(3) 206-210 -> 197-201 us, Bianchi 89-94 -> 81-88 us, same run).
# Inlining is not free: numba deep-copies the callee's IR at every inlined site, so a helper called
# at two sites of one caller (unpack_G in estimate) or a large one (refine_abelian: pair_log_refined
# 8.3 -> 10.3 s inlined) stays a compiled function of its own; a helper compiled once for several
# callers (expm, ad_batch, logm, _inverse_det, _matmul) costs its own compile once per installation;
# expm_frechet, called at one compiled site (the refine), is inlined there (Bianchi VI0 pair_log_refined
# 7.4-7.7 -> 7.2-7.4 s), _project at two sites is not (se(3) pair_log 3.5 -> 3.85 s inlined).
# The starting state and the logarithm of the full state as one compiled call each (the numpy glue
# they replace cost ~10 us of call overhead apiece on one trajectory; the same formulas as
# refimpl._full_state._pack and ._log_complete, which stay the documentation).
@njit(cache=True, nogil=True)
def start(X, Pi, mats, adt, adc, gpart, gi, gj, off, gamma, grav, Pab, y0):
    """``y0[N] = (pi, [Gamma,] G entries, [s])`` from ``X``, ``Pi`` (n, N): ``G = exp(rho(x))``,
    ``Gamma_b = sum_m Ad(g)_mb gamma_m`` (``grav``), ``s = Pab x`` (``Pab`` (k, n), k = 0 without an
    abelian part)."""
    n, N = X.shape
    r = mats.shape[1]
    d = y0.shape[1]
    k = Pab.shape[0]
    xr = np.empty((N, n))
    for j in range(N):
        for a in range(n):
            xr[j, a] = X[a, j]
            y0[j, a] = Pi[a, j]
        for ell in range(k):
            acc = 0.0
            for a in range(n):
                acc += Pab[ell, a] * X[a, j]
            y0[j, d - k + ell] = acc
    G = np.empty((N, r, r), dtype=mats.dtype)
    exp_batch(xr, mats, G)
    if grav:
        Ad = np.empty((N, n, n))
        ad_sparse(G, adt, adc, Ad)
        for j in range(N):
            for b in range(n):
                acc = 0.0
                for m in range(n):
                    acc += Ad[j, m, b] * gamma[m]
                y0[j, n + b] = acc
    pack_G(G, gpart, gi, gj, off, y0)


@njit(cache=True, nogil=True)
def log_residual(xs, mats, adt, adc, Ad, out):
    """``out[N] = max |Ad(exp(rho(x))) - Ad|`` for the rows of ``xs`` (N, n) (inf when not finite):
    how far the logarithm's ``x`` moves what the user reads from ``Ad(g)``."""
    N, n = xs.shape
    r = mats.shape[1]
    G = np.empty((N, r, r), dtype=mats.dtype)
    exp_batch(xs, mats, G)
    Adx = np.empty((N, n, n))
    ad_sparse(G, adt, adc, Adx)
    for it in range(N):
        m = 0.0
        chk = 0.0  # 0.0 * v is NaN iff v is not finite: max() would drop a NaN
        for a in range(n):
            for b in range(n):
                v = abs(Adx[it, a, b] - Ad[it, a, b])
                m = max(m, v)
                chk += 0.0 * v
        out[it] = m if chk == 0.0 and math.isfinite(m) else np.inf


@njit(cache=True, nogil=True, inline="always")
def _residual_final(Ex, mats, proj, adt, adc, cplx, Ad, resid):
    """:func:`log_residual` from ``Ex[N] = exp(rho(x))`` already computed (every row has its
    logarithm here): inf where ``Ad(exp x)`` or ``Ad(g_B)`` is not finite, so that the estimate refuses
    the row (a NaN ``Ad(g_B)`` of an overflowing ``G`` had become 0 and passed, issue 25)."""
    N = Ex.shape[0]
    n = mats.shape[0]
    Adx = np.empty((N, n, n))
    ad_sparse(Ex, adt, adc, Adx)
    for it in range(N):
        m = 0.0
        chk = 0.0  # 0.0 * v is NaN iff v is not finite: max() would drop a NaN
        for a in range(n):
            for b in range(n):
                v = abs(Adx[it, a, b] - Ad[it, a, b])
                m = max(m, v)
                chk += 0.0 * v
        resid[it] = m if chk == 0.0 and math.isfinite(m) else np.inf


@njit(cache=True, nogil=True, inline="always")
def log_state(G, Ad, mats, proj, adt, adc, cplx, ab_mode, xs, ok, resid, kind):
    """The answer's logarithm and its residual in one call: :func:`log_batch` of ``G`` (N, r, r) into
    ``xs`` and, when it accepted every row and no abelian part is to be refined (``ab_mode`` 0; 2: a
    complex representation with an abelian part, refined by the caller), ``resid`` by
    :func:`log_residual` against ``Ad``. Returns whether ``xs`` and ``resid`` are final (else the
    caller completes them, ``refimpl._full_state._log_complete``). ``kind``: :func:`log_batch_exp`'s."""
    Ex = np.empty_like(G)
    log_batch_exp(G, mats, proj, cplx, xs, ok, Ex, kind)
    for j in range(xs.shape[0]):
        if not ok[j]:
            return False
    if ab_mode != 0:
        return False
    _residual_final(Ex, mats, proj, adt, adc, cplx, Ad, resid)
    return True


@njit(cache=True, nogil=True, inline="always")
def log_state_abelian(B, G, Ad, mats, proj, adt, adc, Ppinv, Dr, xs, ok, resid):
    """:func:`log_state_refined` on a representation where :func:`derived_in_translations`: the
    refine's answer in closed form (:func:`log_from_abelian`, ``s`` the last ``k = Ppinv.shape[1]``
    entries of the states ``B``), accepted as :func:`log_batch`'s, then ``resid``; neither the
    logarithm of ``G`` nor the refine (a function of its own: inlining :func:`log_state_refined` and
    pruning the rest cost ~1 s of numba's inlining pass cold). Returns whether ``xs`` and ``resid`` are
    final (else the caller completes the rows not ``ok``)."""
    Ex = np.empty_like(G)
    cplx = (
        proj.shape[1] != mats.shape[1] * mats.shape[2]
    )  # False, not a literal (log_state_refined)
    N, n = xs.shape
    k = Ppinv.shape[1]
    d = B.shape[1]
    r = G.shape[1]
    sj = np.empty(k)
    shape = small_shape(mats, cplx)
    L = np.empty((r, r))
    X = np.empty((r, r))
    x = np.empty(n)
    done = True
    for j in range(N):
        for ell in range(k):
            sj[ell] = B[j, d - k + ell]
        ok[j] = log_from_abelian(sj, Ppinv, Dr, mats, shape, G[j], L) and _accept_log(
            L, G[j], mats, proj, cplx, x, X, Ex[j], xs[j]
        )
        done = done and ok[j]
    if done:
        _residual_final(Ex, mats, proj, adt, adc, cplx, Ad, resid)
    return done


def derived_annihilates(mats, Dr):
    """Whether ``rho([g, g])`` annihilates ``rho(g)`` on both sides: ``rho(D_c) rho(E_a) = rho(E_a)
    rho(D_c) = 0`` for every ``a``, ``c`` (to ``1e-12`` of the sizes: ``D`` comes from an SVD), as on
    the Heisenberg algebras' matrices (their centre is a corner). Then ``exp(X + rho(D w)) = exp(X) +
    rho(D w)`` exactly (every product with ``rho(D w)`` vanishes), and the refine's least squares is
    linear (:func:`log_state_central`). Numpy, run once per representation."""
    mats = np.asarray(mats)
    Dr = np.asarray(Dr)
    if mats.ndim != 3 or Dr.ndim != 3 or Dr.shape[0] == 0 or np.iscomplexobj(mats):
        return False
    scale = max(1.0, float(np.max(np.abs(mats)))) * max(1.0, float(np.max(np.abs(Dr))))
    left = np.einsum("cij,ajk->caik", Dr, mats)
    right = np.einsum("aij,cjk->caik", mats, Dr)
    return bool(np.max(np.abs(left)) <= 1e-12 * scale and np.max(np.abs(right)) <= 1e-12 * scale)


@njit(cache=True, nogil=True, inline="always")
def log_state_central(B, G, Ad, mats, proj, adt, adc, Ppinv, D, Dr, xs, ok, resid):
    """:func:`log_state_refined` on a representation where :func:`derived_annihilates`: the refine's
    answer in closed form. ``x = x0 + D w`` with ``x0 = pinv(P) s`` (``s`` the last ``k`` entries of
    the states ``B``); ``exp(rho(x)) = exp(rho(x0)) + rho(D w)``, so ``w`` minimising
    ``|exp(rho(x)) - G|`` is the linear least squares ``(Dr^T Dr) w = Dr^T vec(G - exp(rho(x0)))``
    (the small ``m x m`` system by :func:`_inverse_det`). Accepted as :func:`log_batch`'s, then
    ``resid``; neither :func:`logm` nor the Gauss-Newton refine. Returns whether ``xs`` and ``resid``
    are final (else the caller completes the rows not ``ok``)."""
    Ex = np.empty_like(G)
    cplx = (
        proj.shape[1] != mats.shape[1] * mats.shape[2]
    )  # False, not a literal (log_state_refined)
    N, n = xs.shape
    k = Ppinv.shape[1]
    m = Dr.shape[0]
    d = B.shape[1]
    r = G.shape[1]
    ws = np.zeros((4, r, r))
    X, E0, L, Xa = ws[0], ws[1], ws[2], ws[3]
    x0 = np.empty(n)
    x = np.empty(n)
    wm = np.zeros((2, m, m))
    DtD, DtDi = wm[0], wm[1]
    inv_ws = np.zeros((m, 2 * m))
    rhs = np.empty(m)
    for a in range(m):
        for c in range(m):
            acc = 0.0
            for i in range(r):
                for j in range(r):
                    acc += Dr[a, i, j] * Dr[c, i, j]
            DtD[a, c] = acc
    if not _inverse_det(DtD, DtDi, inv_ws) > 0.0:
        return False
    done = True
    for jr in range(N):
        for a in range(n):
            acc = 0.0
            for ell in range(k):
                acc += Ppinv[a, ell] * B[jr, d - k + ell]
            x0[a] = acc
        _exp_rho(x0, mats, X, E0)
        for a in range(m):
            acc = 0.0
            for i in range(r):
                for j in range(r):
                    acc += Dr[a, i, j] * (G[jr, i, j] - E0[i, j])
            rhs[a] = acc
        for a in range(n):
            acc = x0[a]
            for c in range(m):
                w = 0.0
                for e in range(m):
                    w += DtDi[c, e] * rhs[e]
                acc += D[a, c] * w
            x[a] = acc
        for i in range(r):  # L = rho(x): _accept_log projects it back to x
            for j in range(r):
                acc = 0.0
                for a in range(n):
                    acc += x[a] * mats[a, i, j]
                L[i, j] = acc
        ok[jr] = _accept_log(L, G[jr], mats, proj, cplx, x0, Xa, Ex[jr], xs[jr])
        done = done and ok[jr]
    if done:
        _residual_final(Ex, mats, proj, adt, adc, cplx, Ad, resid)
    return done


@njit(cache=True, nogil=True, inline="always")
def log_state_refined(B, G, Ad, mats, proj, adt, adc, P, Ppinv, D, Dr, rtol, xs, ok, resid, kind):
    """:func:`log_state` of a real representation with an abelian part: after :func:`log_batch` (when
    it accepted every row) :func:`abelian_batch` with ``s`` the last ``k = P.shape[0]`` entries of the
    states ``B`` (N, d), then ``resid``. ``kind``: :func:`log_batch_exp`'s. Returns whether ``xs`` and
    ``resid`` are final (else the caller completes the rows not ``ok``)."""
    Ex = np.empty_like(G)
    # False (a real representation: proj has r^2 columns), computed rather than written: a literal
    # False is typed Literal[bool] and compiled ad_batch and _project a second time (0.7 s cold)
    cplx = proj.shape[1] != mats.shape[1] * mats.shape[2]
    N, n = xs.shape
    k = P.shape[0]
    d = B.shape[1]
    r = G.shape[1]
    sj = np.empty(k)
    log_batch_exp(G, mats, proj, cplx, xs, ok, Ex, kind)
    for j in range(N):
        if not ok[j]:
            return False
    # abelian_batch's test and refine, written here (one nested compiled level fewer: numba links and
    # re-optimizes every callee's whole call tree into each caller, so depth costs compile time;
    # measured from an empty numba cache, load ~1.2: pair_log_refined 13.9-14.0 -> 12.5 s)
    xj = np.empty(n)
    out = np.empty(n)
    X = np.empty((r, r))
    for j in range(N):
        dev = 0.0
        smax = 0.0
        for ell in range(k):
            sj[ell] = B[j, d - k + ell]
            acc = 0.0
            for a in range(n):
                acc += P[ell, a] * xs[j, a]
            dev = max(dev, abs(acc - sj[ell]))
            smax = max(smax, abs(sj[ell]))
        # refined also when exp(rho(x)) misses G by more than refine_abelian's own floor: an abelian
        # part within rtol of s can still be hundreds of ulp off where Ad(exp x) is steep in it
        # (Bianchi VI0, |x| ~ 9: 500 ulp of x moved Ad(exp x) by 1.2e-10, refusing batch rows)
        gres = 0.0
        gmax = 0.0
        for i in range(r):
            for q in range(r):
                gres = max(gres, abs(Ex[j, i, q] - G[j, i, q]))
                gmax = max(gmax, abs(G[j, i, q]))
        if not (dev > rtol * max(1.0, smax) or gres > LOG_REFINE_FLOOR * r * max(1.0, gmax)):
            continue
        for a in range(n):
            xj[a] = xs[j, a]
        refine_abelian(G[j], xj, sj, P, Ppinv, D, Dr, mats, out)
        moved = False
        for a in range(n):
            moved = moved or out[a] != xs[j, a]
            xs[j, a] = out[a]
        if moved:  # exp(rho(x)) of the refined row again (exp_batch's arithmetic)
            _exp_rho(out, mats, X, Ex[j])
    _residual_final(Ex, mats, proj, adt, adc, cplx, Ad, resid)
    return True


# The entries below are written out (two calls each) rather than calling one inlined body: an
# inlined level of its own cost se(3)'s fully cold pair_log 2.95 -> 3.40 s (one run each, load 2.3;
# written out: 3.03).
@njit(cache=True, nogil=True)
def pair_log(A, B, n, gpart, gi, gj, off, unit, mats, proj, adt, adc, cplx, ab_mode, GB, AdB, est, size, xs, ok, resid):  # fmt: skip
    """:func:`estimate` of the pair ``(A, B)`` and :func:`log_state` of ``B`` in one call (one dispatch
    instead of four on the common protocol call), by :func:`logm`. Returns :func:`log_state`'s flag."""
    estimate(A, B, n, gpart, gi, gj, off, unit, mats, proj, adt, adc, cplx, GB, AdB, est, size)
    return log_state(GB, AdB, mats, proj, adt, adc, cplx, ab_mode, xs, ok, resid, LOG_GENERAL)


@njit(cache=True, nogil=True)
def pair_log_small(A, B, n, gpart, gi, gj, off, unit, mats, proj, adt, adc, cplx, ab_mode, GB, AdB, est, size, xs, ok, resid):  # fmt: skip
    """:func:`pair_log` by :func:`log_small` (its representations: :func:`pair_log_for`)."""
    estimate(A, B, n, gpart, gi, gj, off, unit, mats, proj, adt, adc, cplx, GB, AdB, est, size)
    return log_state(GB, AdB, mats, proj, adt, adc, cplx, ab_mode, xs, ok, resid, LOG_SMALL)


@njit(cache=True, nogil=True)
def pair_log_so4(A, B, n, gpart, gi, gj, off, unit, mats, proj, adt, adc, cplx, ab_mode, GB, AdB, est, size, xs, ok, resid):  # fmt: skip
    """:func:`pair_log` by :func:`_log_so4` (:data:`SHAPE_SO4`: :func:`pair_log_for`)."""
    estimate(A, B, n, gpart, gi, gj, off, unit, mats, proj, adt, adc, cplx, GB, AdB, est, size)
    return log_state(GB, AdB, mats, proj, adt, adc, cplx, ab_mode, xs, ok, resid, LOG_SO4)


@njit(cache=True, nogil=True)
def pair_log_central(A, B, n, gpart, gi, gj, off, mats, proj, adt, adc, P, Ppinv, D, Dr, rtol, GB, AdB, est, size, xs, ok, resid):  # fmt: skip
    """:func:`pair_log_refined` by :func:`log_state_central` (neither :func:`logm` nor the refine)."""
    cplx = proj.shape[1] != mats.shape[1] * mats.shape[2]
    estimate(A, B, n, gpart, gi, gj, off, 0.0, mats, proj, adt, adc, cplx, GB, AdB, est, size)
    return log_state_central(B, GB, AdB, mats, proj, adt, adc, Ppinv, D, Dr, xs, ok, resid)


@njit(cache=True, nogil=True)
def pair_log_so3(A, B, n, gpart, gi, gj, off, unit, mats, proj, adt, adc, cplx, ab_mode, GB, AdB, est, size, xs, ok, resid):  # fmt: skip
    """:func:`pair_log` by :func:`_log_so3` (:data:`SHAPE_SO3`: :func:`pair_log_for`)."""
    estimate(A, B, n, gpart, gi, gj, off, unit, mats, proj, adt, adc, cplx, GB, AdB, est, size)
    return log_state(GB, AdB, mats, proj, adt, adc, cplx, ab_mode, xs, ok, resid, LOG_SO3)


@njit(cache=True, nogil=True)
def pair_log_refined(A, B, n, gpart, gi, gj, off, mats, proj, adt, adc, P, Ppinv, D, Dr, rtol, GB, AdB, est, size, xs, ok, resid):  # fmt: skip
    """:func:`pair_log` with :func:`log_state_refined` (a real representation with an abelian part)."""
    # False, not a literal (see log_state_refined)
    cplx = proj.shape[1] != mats.shape[1] * mats.shape[2]
    estimate(A, B, n, gpart, gi, gj, off, 0.0, mats, proj, adt, adc, cplx, GB, AdB, est, size)
    return log_state_refined(B, GB, AdB, mats, proj, adt, adc, P, Ppinv, D, Dr, rtol, xs, ok, resid, LOG_GENERAL)  # fmt: skip


@njit(cache=True, nogil=True)
def pair_log_refined_small(A, B, n, gpart, gi, gj, off, mats, proj, adt, adc, P, Ppinv, D, Dr, rtol, GB, AdB, est, size, xs, ok, resid):  # fmt: skip
    """:func:`pair_log_refined` by :func:`log_small`."""
    cplx = proj.shape[1] != mats.shape[1] * mats.shape[2]
    estimate(A, B, n, gpart, gi, gj, off, 0.0, mats, proj, adt, adc, cplx, GB, AdB, est, size)
    return log_state_refined(B, GB, AdB, mats, proj, adt, adc, P, Ppinv, D, Dr, rtol, xs, ok, resid, LOG_SMALL)  # fmt: skip


@njit(cache=True, nogil=True)
def pair_log_abelian(A, B, n, gpart, gi, gj, off, mats, proj, adt, adc, P, Ppinv, D, Dr, rtol, GB, AdB, est, size, xs, ok, resid):  # fmt: skip
    """:func:`pair_log_refined` by :func:`log_from_abelian` (neither :func:`logm` nor the refine)."""
    cplx = proj.shape[1] != mats.shape[1] * mats.shape[2]
    estimate(A, B, n, gpart, gi, gj, off, 0.0, mats, proj, adt, adc, cplx, GB, AdB, est, size)
    return log_state_abelian(B, GB, AdB, mats, proj, adt, adc, Ppinv, Dr, xs, ok, resid)


def pair_log_for(mats, cplx, Dr=None):
    """The compiled pair and logarithm for the representation ``mats`` (``Dr``: ``rho`` of ``[g, g]``'s
    basis when the abelian part is refined in the compiled code, :func:`pair_log_refined`'s arguments;
    else None, :func:`pair_log`'s), decided per representation, never per value:
    :func:`pair_log_abelian` where :func:`derived_in_translations`, :func:`pair_log_central` where
    :func:`derived_annihilates`, the ``_small`` entries where
    :func:`small_shape` applies, else the general ones. Each is its own compiled function, so a
    structure compiles only the logarithm it uses. The tests run the compiled code; this decision
    runs their Python (``py_func``: the same source, nothing compiled for it)."""
    shape = small_shape.py_func(mats, cplx)
    if Dr is None:
        if shape == SHAPE_SO4:
            return pair_log_so4
        if shape == SHAPE_SO3:
            return pair_log_so3
        return pair_log_small if shape != SHAPE_GENERAL else pair_log
    if shape >= 0 and derived_in_translations.py_func(Dr, shape):
        return pair_log_abelian
    if derived_annihilates(mats, Dr):
        return pair_log_central
    return pair_log_refined_small if shape != SHAPE_GENERAL else pair_log_refined
