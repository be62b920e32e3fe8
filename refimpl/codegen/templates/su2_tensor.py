"""Template of the compiled su(2) Poisson tensor kernel (:func:`refimpl.codegen.tensors.su2_source`).

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
