"""Invariants of the flows: energy (twee10, twee15), Casimirs of the reduced brackets (drie7,
drie12) and the momentum map of the left action; derivations in :mod:`refimpl.flows`."""

from __future__ import annotations

import mpmath
import numpy as np

from .. import _fast_kernels as _fast
from .._frames import frames
from .reference import ModelMP

__all__ = ["energy", "casimirs", "momentum_map"]


def energy(inertia, potential, pi, Gamma=None):
    """``H = 1/2 pi.I^-1 pi - Gamma.L`` per point (twee10, twee15); arrays (..., n)."""
    Iinv = np.linalg.inv(np.asarray(inertia, dtype=float))
    pi = np.asarray(pi, dtype=float)
    H = 0.5 * np.einsum("...a,ab,...b->...", pi, Iinv, pi)
    if potential is not None and Gamma is not None:
        H = H - np.asarray(Gamma, dtype=float) @ np.asarray(potential["L"], dtype=float)
    return H


def casimirs(f, theta, pi, Gamma=None):
    """Casimirs of the reduced bracket for su(2)/so(3) with Upsilon = 0 (dict name -> array).

    ``|pi'|^2`` (V = 0) with ``pi' = pi + xi``; with gravity ``|Gamma|^2`` and
    ``pi'.Gamma`` (Euler-Poisson; for ``xi != 0`` the coupling term is
    ``pi'.Gamma`` because ``pi'`` obeys the untwisted equations, drie12).
    """
    f = np.asarray(f, dtype=float)
    if not _fast._is_su2(f):
        raise ValueError("casimirs: written for su(2)/so(3) (f = epsilon)")
    xi = _fast._su2_theta_to_xi(np.asarray(theta, dtype=float))
    q = np.asarray(pi, dtype=float) + xi
    if Gamma is None:
        return {"|pi'|^2": np.sum(q * q, axis=-1)}
    G = np.asarray(Gamma, dtype=float)
    return {"|Gamma|^2": np.sum(G * G, axis=-1), "pi'.Gamma": np.sum(q * G, axis=-1)}


def momentum_map(f, theta, x, pi, *, dps: int | None = None):
    """``J = K(g) pi - A(x)^T Theta x`` for ``g = exp(x)`` (module docstring); conserved when V = 0.

    ``dps=None``: float64 (one point, arrays (n,)); ``dps=int``: mpmath at that precision.
    """
    if dps is None:
        fr = frames(f, np.asarray(x, dtype=float))
        th = np.asarray(theta, dtype=float)
        x = np.asarray(x, dtype=float)
        return fr["K"] @ np.asarray(pi, dtype=float) - fr["A"].T @ (th @ x)
    with mpmath.workdps(dps):
        model = ModelMP(
            f,
            theta,
            np.zeros_like(np.asarray(theta, dtype=object)),
            np.eye(len(np.asarray(x))),
            None,
        )
        xv = mpmath.matrix([mpmath.mpf(v) if not isinstance(v, str) else mpmath.mpf(v) for v in x])
        pv = mpmath.matrix([mpmath.mpf(v) for v in pi])
        K = mpmath.expm(-model.ad(xv)).T
        return K * pv - model.cocycle_term(xv)
