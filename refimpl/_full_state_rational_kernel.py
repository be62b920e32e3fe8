"""The compiled kernel of :mod:`refimpl._full_state_rational` for every structure (``Upsilon != 0``).

The field is given as tables (arguments, never literals), so numba compiles this module once per
argument types -- once in total -- and ``cache=True`` keeps the machine code on disk: a new algebra,
inertia, ``Theta``, ``Upsilon`` or representation costs no compilation (the generated kernel of
:mod:`refimpl.codegen.full_state_rational` unrolls the same recurrence per structure, for long runs).

The recurrence (per step ``S_0``, ``Psi_0 = 1 + Upsilon S_0``, its inverse ``Mi`` and
``cond_inf(Psi_0)``; per order ``k``, all sums over the nonzero entries of ``f`` and of ``rho``):

    ``r_k = I^-1 pi_k + Upsilon G_L Gamma_k - Upsilon sum_{j=1..k} S_j Omega_{k-j}``,  ``Omega_k = Mi r_k``,
    ``q_k = G_L Gamma_k + Theta dK_k - sum_{j=0..k} S_j dK_{k-j} - sum_{j=1..k} S_j^T w_{k-j}``,
    ``pidot_k = Mi^T q_k``, ``pi_{k+1} = pidot_k / (k+1)``, ``w_k = Upsilon^T pidot_k``,
    ``Gamma_{k+1} = sum_{j=0..k} f.(Omega_j, Gamma_{k-j}) / (k+1)``,
    ``M_k = rho(Omega_k)``, ``G_{k+1} = sum_{a=0..k} G_a M_{k-a} / (k+1)``, ``s_{k+1} = P Omega_k / (k+1)``

(``S_j = f.pi_j`` for ``j >= 1``, ``dK = I^-1 pi``): the recurrence of :mod:`refimpl._compiled_rational`
with ``G`` of :mod:`refimpl._full_state`. Tables (``int64`` unless said otherwise):

``tm, ta, tb, fv``
    the nonzero ``f^m_ab`` (float ``fv``); ``svm, svb`` the distinct pairs ``(m, b)`` and ``sv_of[t]``
    the pair of entry ``t``; ``stm, sta``, ``st_of`` likewise for ``(m, a)``; ``gpa, gpm``, ``gp_of`` for
    ``(a, m)`` (gravity);
``mptr, mb, mc``
    ``M_k[e] = sum mc[t] Omega_k[mb[t]]`` for ``t`` in ``mptr[e]..mptr[e+1]`` (float ``mc``);
``pu, pw, pconst``
    the products ``G[pu] M[pw]`` (``pconst``: ``G[pu]`` is constant, its ``a = 0`` term only);
``gvar, gptr, gprod, gsign``
    per varying entry ``gvar[c]`` of ``G``: ``G_{k+1} = sum gsign prod[gprod] / (k+1)``;
``Pab``
    ``(n_s, n)`` float, the abelian part's ``ds/dt = P Omega``.

The order body is the intrinsic :func:`refimpl.codegen._full_state_ir.rational_order` (LLVM IR, the
tables read at run time, each operation as in the numba Python loops it replaced and in the same
order): first call from empty caches (modified su(3), the kernel alone, CPU, load 2.1) 3.43 -> 2.66 s;
end states bitwise equal and per call faster (modified_su3 over T = 10, interleaved, best of 50, CPU,
load 1.5-2.2: 124.9 -> 104.2 us at 1e-6, 326.5 -> 265.4 us at 1e-13).

Status codes as the su(2) rational kernel: -1 non-finite, -2 degenerate set (a zero pivot, or the
sensitivity of the solve ``||Psi_0^-1||_inf (1 + ||S_0||_inf ||Upsilon||_inf) > cond_max``, which is
at least ``cond_inf(Psi_0)`` and sees ``Delta -> 0`` on 2-dimensional algebras too), -3 step budget, -4 no step (the step fell below ``STALL t`` or the
coefficients overflowed: a real singularity ahead).
"""

from __future__ import annotations

import math

import numpy as np

from .codegen._full_state_ir import rational_order
from .codegen.rational import STALL

try:
    from numba import njit
except ImportError:  # pragma: no cover - the plain-Python path

    def njit(*a, **kw):
        return (lambda fn: fn) if not a else a[0]


__all__ = ["adaptive", "invert_cond", "start_degenerate", "start_degenerate_su2"]


@njit(cache=True, nogil=True)
def invert_cond(A, Ainv, M):
    """Gauss-Jordan with partial pivoting, ``Ainv = A^-1`` (``M`` an (n, 2n) work array); returns
    ``cond_inf(A)``, ``inf`` when a pivot is zero (the algorithm of the rational kernels' ``invert``)."""
    n = A.shape[0]
    anorm = 0.0
    for i in range(n):
        r = 0.0
        for j in range(n):
            M[i, j] = A[i, j]
            M[i, n + j] = 1.0 if i == j else 0.0
            r += abs(A[i, j])
        anorm = max(anorm, r)
    for c in range(n):
        p = c
        for i in range(c + 1, n):
            if abs(M[i, c]) > abs(M[p, c]):
                p = i
        if not (abs(M[p, c]) > 0.0):
            return np.inf
        if p != c:
            for j in range(2 * n):
                tmp = M[c, j]
                M[c, j] = M[p, j]
                M[p, j] = tmp
        piv = 1.0 / M[c, c]
        for j in range(2 * n):
            M[c, j] *= piv
        for i in range(n):
            if i != c:
                g = M[i, c]
                if g != 0.0:
                    for j in range(2 * n):
                        M[i, j] -= g * M[c, j]
    inorm = 0.0
    for i in range(n):
        r = 0.0
        for j in range(n):
            Ainv[i, j] = M[i, n + j]
            r += abs(M[i, n + j])
        inorm = max(inorm, r)
    return anorm * inorm


# the order body as one intrinsic, IR version 1 (numba's cache keys on this file: see rational_order)
_order = rational_order()


@njit(cache=True, nogil=True, fastmath={"contract"})
def adaptive(y0, T, tol, P, max_steps, grav, th, U, Ii, GL, UGL, tm, ta, tb, fv, svm, svb, sv_of, stm, sta, st_of, gpa, gpm, gp_of, ng, mptr, mb, mc, pu, pw, pconst, gvar, gptr, gprod, gsign, Pab, cond_max, out, nsteps, tend, conds):  # fmt: skip
    """Adaptive Taylor over ``[0, T]`` for every row ``(pi, [Gamma,] G entries, [s])`` of ``y0`` (N, d),
    row ``i`` at the local tolerance ``tol[i]`` and the order ``P[i]`` (arrays of N; a ``y0`` of one row
    starts every row): ``out`` the end states, ``nsteps`` the steps (negative: the status), ``tend``
    the time reached, ``conds`` the largest sensitivity seen. Each row's run is the same whatever the
    other rows are (the work arrays are sized for the largest order; a row reads only its own
    orders' coefficients, written before they are read): one trajectory's pair ``A``, ``B`` is one call."""
    N = tol.shape[0]
    n0 = y0.shape[0]
    n = th.shape[0]
    Pmax = 2
    for it in range(N):
        Pmax = max(Pmax, P[it])
    P1 = Pmax + 1
    ns = Pab.shape[0]
    nm = mptr.shape[0] - 1
    nvar = gvar.shape[0]
    goff = 2 * n if grav else n
    soff = goff + ng
    PI = np.zeros((n, P1))
    GA = np.zeros((n, P1))
    OM = np.zeros((n, P1))
    DK = np.zeros((n, P1))
    W = np.zeros((n, P1))
    GG = np.zeros((max(ng, 1), P1))
    MM = np.zeros((max(nm, 1), P1))
    SS = np.zeros((max(ns, 1), P1))
    S0 = np.zeros((n, n))
    Psi = np.zeros((n, n))
    Mi = np.zeros((n, n))
    GJ = np.zeros((n, 2 * n))
    po = np.zeros(max(svm.shape[0], 1))
    pd = np.zeros(max(svm.shape[0], 1))
    pwv = np.zeros(max(stm.shape[0], 1))
    og = np.zeros(max(gpa.shape[0], 1))
    gm = np.zeros(max(pu.shape[0], 1))
    r = np.zeros(n)
    q = np.zeros(n)
    cs = np.zeros(n)
    nrow = n * (2 if grav else 1) + nvar + ns
    comp = np.zeros(nrow)
    sgn = 1.0 if T >= 0 else -1.0
    Tabs = abs(T)
    stall = STALL
    unorm = 0.0
    for a in range(n):
        ra = 0.0
        for b in range(n):
            ra += abs(U[a, b])
        unorm = max(unorm, ra)
    ntr = tm.shape[0]
    series = (PI, GA, OM, DK, W, GG, MM, SS)
    work = (po, pd, pwv, og, gm, r, q, cs)
    mats = (Mi, Ii, U, UGL, th, GL, Pab)
    tabs = (tm, ta, tb, fv, svm, svb, sv_of, stm, sta, st_of, gpa, gpm, gp_of, mptr, mb, mc, pu, pw, pconst, gvar, gptr, gprod, gsign)  # fmt: skip
    for it in range(N):
        Pi = P[it]
        tl = tol[it]
        damp = math.exp(-0.7 / (Pi - 1))
        e1 = 1.0 / (Pi - 1)
        e2 = 1.0 / Pi
        i0 = it if n0 > 1 else 0
        for a in range(n):
            PI[a, 0] = y0[i0, a]
            if grav:
                GA[a, 0] = y0[i0, n + a]
        for v in range(ng):
            GG[v, 0] = y0[i0, goff + v]
        for ell in range(ns):
            SS[ell, 0] = y0[i0, soff + ell]
        for c in range(nrow):
            comp[c] = 0.0
        t = 0.0
        nst = 0
        status = 0
        cond_seen = 0.0
        while t < Tabs:
            # ---- Psi_0 = 1 + U S_0, S_0 = f.pi_0 - Theta; its inverse and condition
            for a in range(n):
                for b in range(n):
                    S0[a, b] = -th[a, b]
            for e in range(ntr):
                S0[ta[e], tb[e]] += fv[e] * PI[tm[e], 0]
            for a in range(n):
                for b in range(n):
                    acc = 1.0 if a == b else 0.0
                    for c in range(n):
                        acc += U[a, c] * S0[c, b]
                    Psi[a, b] = acc
            cnd = invert_cond(Psi, Mi, GJ)
            if (
                cnd < np.inf
            ):  # the sensitivity ||Psi_0^-1|| (1 + ||S_0|| ||U||) (docs/conventions.md)
                mn = 0.0
                sn = 0.0
                for a in range(n):
                    ra = 0.0
                    sa = 0.0
                    for b in range(n):
                        ra += abs(Mi[a, b])
                        sa += abs(S0[a, b])
                    mn = max(mn, ra)
                    sn = max(sn, sa)
                cnd = mn * (1.0 + sn * unorm)
            if not (cnd <= cond_max):
                status = -2
                cond_seen = cnd
                break
            cond_seen = max(cond_seen, cnd)
            for k in range(Pi):  # the order-k body: LLVM IR (codegen._full_state_ir.rational_order)
                _order(k, grav, series, work, mats, tabs)
            # ---- the step (Jorba-Zou on pi, Gamma and the varying G)
            xn = 0.0
            a1 = 0.0
            a2 = 0.0
            for a in range(n):
                xn = max(xn, abs(PI[a, 0]))
                a1 = max(a1, abs(PI[a, Pi - 1]))
                a2 = max(a2, abs(PI[a, Pi]))
                if grav:
                    xn = max(xn, abs(GA[a, 0]))
                    a1 = max(a1, abs(GA[a, Pi - 1]))
                    a2 = max(a2, abs(GA[a, Pi]))
            for c in range(nvar):
                v = gvar[c]
                xn = max(xn, abs(GG[v, 0]))
                a1 = max(a1, abs(GG[v, Pi - 1]))
                a2 = max(a2, abs(GG[v, Pi]))
            s = tl * max(1.0, xn)
            h = np.inf
            if a1 > 0.0:
                h = (s / a1) ** e1
            if a2 > 0.0:
                h = min(h, (s / a2) ** e2)
            h *= damp
            if not (h > stall * t):
                status = -4
                break
            if t + h >= Tabs:
                h = Tabs - t
                t = Tabs
            else:
                t += h
            hs = sgn * h
            fin = True
            c = 0
            for blk in range(4):
                if blk == 0:
                    X = PI
                    cnt = n
                elif blk == 1:
                    X = GA
                    cnt = n if grav else 0
                elif blk == 2:
                    X = GG
                    cnt = nvar
                else:
                    X = SS
                    cnt = ns
                for i0 in range(cnt):
                    i = gvar[i0] if blk == 2 else i0
                    z = X[i, Pi]
                    for kk in range(Pi - 1, 0, -1):
                        z = z * hs + X[i, kk]
                    z = z * hs - comp[c]
                    w = X[i, 0] + z
                    comp[c] = (w - X[i, 0]) - z
                    X[i, 0] = w
                    if not math.isfinite(w):
                        fin = False
                    c += 1
            nst += 1
            if not fin:
                status = -1
                break
            if nst > max_steps:
                status = -3
                break
        for a in range(n):
            out[it, a] = PI[a, 0]
            if grav:
                out[it, n + a] = GA[a, 0]
        for v in range(ng):
            out[it, goff + v] = GG[v, 0]
        for ell in range(ns):
            out[it, soff + ell] = SS[ell, 0]
        nsteps[it] = nst if status == 0 else status
        tend[it] = sgn * t
        conds[it] = cond_seen


@njit(cache=True, nogil=True)
def start_degenerate(p, f, th, U, n_ups, c):
    """Whether the start ``pi = p`` (1-D, ``x = 0``) lies on the degenerate set: the rule of
    :func:`refimpl._fast_kernels._degenerate_at_origin` (the flows' start check) compiled for one
    point. ``S_aj = p_i f^i_aj - Theta_aj``, ``Psi = 1 + Upsilon S``; with Frobenius norms ``cond =
    ||Psi|| ||Psi^-1|| / n`` and ``sens = ||Psi^-1|| (1 + ||S|| ||Upsilon||) / sqrt(n)``
    (:func:`refimpl._fast_kernels._psi_cond_sens`; ``n_ups = ||Upsilon||``), the point is degenerate
    unless ``cond c < 1`` and ``sens c < 1`` (``c = n C_P eps``); an exactly singular ``Psi`` (a zero
    pivot) or a NaN is degenerate."""
    n = th.shape[0]
    S = np.empty((n, n))
    Psi = np.empty((n, n))
    Pi = np.empty((n, n))
    GJ = np.empty((n, 2 * n))
    fs = 0.0
    for a in range(n):
        for j in range(n):
            acc = 0.0
            for i in range(n):
                acc += p[i] * f[i, a, j]
            acc -= th[a, j]
            S[a, j] = acc
            fs += acc * acc
    fp = 0.0
    for a in range(n):
        for b in range(n):
            acc = 0.0
            for k in range(n):
                acc += U[a, k] * S[k, b]
            if a == b:
                acc += 1.0
            Psi[a, b] = acc
            fp += acc * acc
    if not invert_cond(Psi, Pi, GJ) < np.inf:  # a zero pivot (or NaN): exactly singular
        return True
    fi = 0.0
    for a in range(n):
        for b in range(n):
            fi += Pi[a, b] * Pi[a, b]
    fi = math.sqrt(fi)
    cond = math.sqrt(fp) * fi / n
    sens = fi * (1.0 + math.sqrt(fs) * n_ups) / math.sqrt(n)
    return not (cond * c < 1.0 and sens * c < 1.0)


@njit(cache=True, nogil=True)
def start_degenerate_su2(p, xi, tau, lim):
    """The same for su(2) (``f = eps``) by its closed form, the rule of the su(2) Poisson kernel
    (:func:`refimpl._fast_kernels._su2_poisson_chunk` at ``x = 0``): ``q = p + xi`` (``Theta = -xi.f``),
    ``Upsilon^mn = tau_l eps_lmn``, ``C1 = 1 - q.tau``, ``sens = sqrt(3 - 2 q.tau + |tau|^2 |q|^2)
    (1 + 2 |q| |tau|) / (|C1| sqrt(3))``; degenerate unless ``sens < lim`` (``1 / (3 C_P eps)``) and
    ``C1 != 0``."""
    q0, q1, q2 = p[0] + xi[0], p[1] + xi[1], p[2] + xi[2]
    qt = tau[0] * q0 + tau[1] * q1 + tau[2] * q2
    c1 = 1.0 - qt
    if c1 == 0.0:
        return True
    tn2 = tau[0] * tau[0] + tau[1] * tau[1] + tau[2] * tau[2]
    qn2 = q0 * q0 + q1 * q1 + q2 * q2
    ni2 = qn2 * tn2 - 2.0 * qt + 3.0
    g = (1.0 + math.sqrt(qn2) * (2.0 * math.sqrt(tn2))) * (abs(1.0 / c1) * (1.0 / math.sqrt(3.0)))
    return not (math.sqrt(ni2) * g < lim)
