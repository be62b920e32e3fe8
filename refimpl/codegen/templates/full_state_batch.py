"""Template of the lane-batched full-state Taylor kernel (:func:`refimpl.codegen.full_state_batch.
batch_source`): ``W`` trajectories side by side, the Taylor coefficients laid out ``V[k, row, lane]``.

Read as text by :func:`refimpl.codegen._loader.template`: the lines above the body mark only
define the placeholders for the linters; ``__NAME__`` is replaced by :func:`refimpl.codegen._loader.fill`
(a placeholder alone on its line replaces the whole line). The generated blocks are the module's head
(``__HEAD__``: the structure's ``SPEC`` and its intrinsics ``_order``, the order body of the
recurrence on every lane, and ``_load``, the numbers as a tuple; :mod:`refimpl.codegen._full_state_ir`)
and the lanes of the compensated Horner update (``__HLOAD__``, ``__ZLOAD__``, ``__ZSTEP__``,
``__ZADD__``); ``__NV__`` rows of ``V`` (state, then derived), ``__D__`` state variables, ``__W__``
lanes, ``__NCOEF__`` numbers.

Lanes: each lane runs one trajectory with its own time, step and step count -- the step sequence of
the single-trajectory kernel (:mod:`refimpl._full_state_kernel`), so each trajectory keeps its own
error; a lane whose trajectory ends (reached ``T``, or failed: status ``-1`` non-finite, ``-3`` step
budget, ``-4`` no positive step) writes its row and takes the next trajectory of the queue; an idle
lane holds the zero state (a fixed point) and steps by ``0``.
"""

# The body is the generated text byte for byte (its hash is the kernels' cache key): the
# formatter leaves it alone, and the import layout and names used only by generated code are kept.
# ruff: noqa: E402, I001, F401, F841
# fmt: off
__HEAD__ = __HLOAD__ = __ZLOAD__ = __ZSTEP__ = __ZADD__ = _order = _load = None
__NV__ = __D__ = __W__ = __NCOEF__ = None
# ---- template body ----

import math
import numpy as np
from numba import njit
__HEAD__


@njit(cache=True, nogil=True, fastmath={'contract'})
def adaptive_batch(y0, T, tol, P, max_steps, c, vrow, srow, out, nsteps):
    if c.shape[0] != __NCOEF__ or y0.shape[1] != __D__ or P < 2:
        raise ValueError('adaptive_batch: c, y0 or P do not fit the structure')
    C = _load(c)
    N = y0.shape[0]
    nvar = vrow.shape[0]
    V = np.zeros((P + 1, __NV__, __W__))
    comp = np.zeros((max(nvar, 1), __W__))
    tl = np.zeros(__W__)
    hv = np.zeros(__W__)
    who = np.full(__W__, -1, dtype=np.int64)
    nst = np.zeros(__W__, dtype=np.int64)
    stat = np.zeros(__W__, dtype=np.int64)
    sgn = 1.0 if T >= 0 else -1.0
    Tabs = abs(T)
    damp = math.exp(-0.7 / (P - 1))
    e1 = 1.0 / (P - 1)
    e2 = 1.0 / P
    nxt = 0
    live = 0
    for l in range(__W__):
        if nxt < N:
            for q in range(__D__):
                V[0, q, l] = y0[nxt, q]
            who[l] = nxt
            nxt += 1
            live += 1
    while live > 0:
        for k in range(P):
            _order(V, k, C)
        for l in range(__W__):
            hv[l] = 0.0
            if who[l] < 0:
                continue
            xn = 0.0
            a1 = 0.0
            a2 = 0.0
            for q in range(srow.shape[0]):
                o = srow[q]
                xn = max(xn, abs(V[0, o, l]))
                a1 = max(a1, abs(V[P - 1, o, l]))
                a2 = max(a2, abs(V[P, o, l]))
            s = tol * max(1.0, xn)
            h = np.inf
            if a1 > 0.0:
                h = (s / a1) ** e1
            if a2 > 0.0:
                h = min(h, (s / a2) ** e2)
            h *= damp
            if not (h > 0.0):
                stat[l] = -4
                continue
            if tl[l] + h >= Tabs:
                h = Tabs - tl[l]
                tl[l] = Tabs
            else:
                tl[l] += h
            hv[l] = sgn * h
        __HLOAD__
        for cv in range(nvar):
            o = vrow[cv]
            __ZLOAD__
            for kk in range(P - 1, 0, -1):
                __ZSTEP__
            __ZADD__
        for l in range(__W__):
            if who[l] < 0:
                continue
            if stat[l] == 0:
                nst[l] += 1
                for cv in range(nvar):
                    if not math.isfinite(V[0, vrow[cv], l]):
                        stat[l] = -1
                if nst[l] > max_steps:
                    stat[l] = -3
            if stat[l] == 0 and tl[l] < Tabs:
                continue
            it = who[l]
            for q in range(__D__):
                out[it, q] = V[0, q, l] if stat[l] == 0 else np.nan
            nsteps[it] = nst[l] if stat[l] == 0 else stat[l]
            for cv in range(nvar):
                comp[cv, l] = 0.0
            tl[l] = 0.0
            nst[l] = 0
            stat[l] = 0
            if nxt < N:
                for q in range(__D__):
                    V[0, q, l] = y0[nxt, q]
                who[l] = nxt
                nxt += 1
            else:
                for q in range(__D__):
                    V[0, q, l] = 0.0
                who[l] = -1
                live -= 1
