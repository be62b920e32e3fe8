"""Frames of canonical coordinates of the first kind, ``g = exp(x^a e_a)`` (twee1, twee3).

* ``A = L(g^-1, g) = phi1(-ad_x)``: the coframe, ``Omega_L = A xdot``;
* ``L = L(g, e) = phi1(-ad_x)^-1``: the frame, ``e^L_a = L[:, a] . d/dx``;
* ``Ad = Ad(g) = exp(ad_x)``; ``K = K(g) = Ad(g^-1)^T`` (coadjoint, twee3).

(The paper defines ``L(g, h)`` as a derivative in ``g`` but uses the
derivative in ``h``; docs/conventions.md records the erratum.)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _fast_kernels as fast
from ._algebra import LieAlgebra
from ._phi import phi1
from ._reference_core import ReferenceCore
from ._validate import check_structure_constants

__all__ = ["frames"]


def frames(f: Any, x: Any, *, dps: int | None = None, route: str = "series") -> dict:
    """``{"A", "L", "Ad", "K"}`` at ``x``.

    ``dps=None``: float64 numpy arrays, batched over leading axes of ``x``
    (the fast implementation's kernels). ``dps=int``: object arrays of mpmath
    numbers at that precision, one point, by the reference's ``route``
    (``"series"`` or ``"vanloan"``); exact inputs are honoured.
    """
    if dps is None:
        ff = check_structure_constants(f.f if isinstance(f, LieAlgebra) else f)
        n = ff.shape[0]
        xa = np.asarray(x, dtype=float)
        if xa.shape[-1:] != (n,):
            raise ValueError(f"x must have last axis {n}, got {xa.shape}")
        if not np.all(np.isfinite(xa)):
            raise ValueError("x contains NaN or infinity")
        shape = xa.shape[:-1]
        X = xa.reshape(-1, n)
        adx = (X @ ff.transpose(1, 0, 2).reshape(n, n * n)).reshape(-1, n, n)
        L, _ = fast._frames_generic(adx)
        A = phi1(-adx)
        Ad = fast._expm_batch(adx, su2=False)
        K = np.linalg.inv(Ad).transpose(0, 2, 1)
        return {k: v.reshape(shape + (n, n)) for k, v in {"A": A, "L": L, "Ad": Ad, "K": K}.items()}
    ref = ReferenceCore(dps)
    with ref._prec():
        F = ref._algebra_mp(f)
        xv = ref._vec(x, len(F), "x")
        fr = ref.frames_mp(F, xv, route=route)
        out = {}
        for key in ("A", "L", "Ad", "K"):
            m = fr[key]
            out[key] = np.array(
                [[m[i, j] for j in range(m.cols)] for i in range(m.rows)], dtype=object
            )
        return out
