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
