"""Template of the compiled Taylor loop kernels (:func:`refimpl.codegen.taylor.loop_source`):
the order is an argument; the body of ``coefficients`` is generated per structure.

Read as text by :func:`refimpl.codegen._loader.template`: the lines above the body mark only
define the placeholders for the linters; ``__NAME__`` is replaced by :func:`refimpl.codegen._loader.fill`
(a placeholder alone on its line replaces the whole line)."""

# The body is the generated text byte for byte (its hash is the kernels' cache key): the
# formatter leaves it alone, and the import layout and names used only by generated code are kept.
# ruff: noqa: E402, I001, F401, F841
# fmt: off
__COEFF__ = None
# ---- template body ----

import math
import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def coefficients(Y, P, q, l):
    __COEFF__


@njit(cache=True, nogil=True)
def horner(Y, P, h):
    for c in range(Y.shape[0]):
        s = Y[c, P]
        for k in range(P - 1, -1, -1):
            s = s * h + Y[c, k]
        Y[c, 0] = s


@njit(cache=True, nogil=True)
def fixed(y0, h, nsteps, P, q, l, out):
    N, d = y0.shape
    Y = np.zeros((d, P + 1))
    for n in range(N):
        for c in range(d):
            Y[c, 0] = y0[n, c]
        for _ in range(nsteps):
            coefficients(Y, P, q, l)
            horner(Y, P, h)
        for c in range(d):
            out[n, c] = Y[c, 0]


@njit(cache=True, nogil=True)
def adaptive(y0, T, tol, P, max_steps, q, l, out, nsteps):
    N, d = y0.shape
    Y = np.zeros((d, P + 1))
    sgn = 1.0 if T >= 0 else -1.0
    Tabs = abs(T)
    damp = math.exp(-0.7 / (P - 1))
    e1 = 1.0 / (P - 1)
    e2 = 1.0 / P
    for n in range(N):
        for c in range(d):
            Y[c, 0] = y0[n, c]
        t = 0.0
        k = 0
        ok = True
        while t < Tabs:
            coefficients(Y, P, q, l)
            xn = 0.0
            a1 = 0.0
            a2 = 0.0
            for c in range(d):
                xn = max(xn, abs(Y[c, 0]))
                a1 = max(a1, abs(Y[c, P - 1]))
                a2 = max(a2, abs(Y[c, P]))
            s = tol * max(1.0, xn)
            h = np.inf
            if a1 > 0.0:
                h = (s / a1) ** e1
            if a2 > 0.0:
                h = min(h, (s / a2) ** e2)
            h *= damp
            if not (h > 0.0):
                ok = False
                break
            if t + h >= Tabs:
                h = Tabs - t
                t = Tabs
            else:
                t += h
            horner(Y, P, sgn * h)
            k += 1
            fin = True
            for c in range(d):
                if not math.isfinite(Y[c, 0]):
                    fin = False
            if not fin or k > max_steps:
                ok = False
                break
        for c in range(d):
            out[n, c] = Y[c, 0] if ok else np.nan
        nsteps[n] = k if ok else -1
