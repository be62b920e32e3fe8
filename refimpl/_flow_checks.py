"""The checks of a flow request shared by the fast and the reference flows: the time span.

Plain floats and ints are checked here directly; exact inputs (``Fraction``, ``"1/2"``, mpf, sympy) go
through the project's exact reader (:func:`refimpl._reference_core._to_mpf`) and are rounded once."""

from __future__ import annotations

import math

import mpmath
import numpy as np

from ._reference_core import _to_mpf

__all__ = ["check_finite", "check_time", "finite_one", "load_point", "point_max"]

_PLAIN = (float, int, np.floating, np.integer)


def check_time(t, name: str = "t", *, allow_negative: bool = False) -> float:
    """A time span must be a finite real number (>= 0 unless ``allow_negative``: flows run backwards too).

    Exact inputs are accepted (int, Fraction, ``"1/2"``, mpf, sympy); complex numbers (even with a zero
    imaginary part), NaN, infinities and non-numbers are refused with a ValueError naming ``name``."""
    cond = "a finite real number" + ("" if allow_negative else " >= 0")
    if isinstance(t, (complex, np.complexfloating, bool)) or type(t).__name__ == "mpc":
        raise ValueError(f"{name} must be {cond}, got {t!r}")
    if isinstance(t, _PLAIN):
        try:
            tv = float(t)
        except OverflowError:  # an int beyond float64
            raise ValueError(f"{name} must be {cond}, got {t!r}") from None
    else:
        try:
            with mpmath.workdps(30):
                tv = float(_to_mpf(t))  # exact inputs accepted: Fraction, "1/2", mpf, sympy
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be {cond}, got {t!r}") from None
    if not math.isfinite(tv) or (tv < 0 and not allow_negative):
        raise ValueError(f"{name} must be {cond}, got {t!r}")
    return tv


def _point_max_py(x0, pi0, bound: float) -> float:
    """:func:`point_max` without numba."""
    xl, pl = x0.tolist(), pi0.tolist()
    if not all(abs(v) <= bound for v in xl + pl):  # NaN fails the comparison
        return -1.0
    return max(map(abs, pl), default=0.0)


def _load_point_py(x0, pi0, X, P, bound: float) -> float:
    """:func:`load_point` without numba."""
    pmax = _point_max_py(x0, pi0, bound)
    if pmax >= 0.0:
        X[:, 0], P[:, 0] = x0, pi0
    return pmax


try:  # numba is a core dependency; the plain-Python path keeps the package usable without it
    from numba import njit
except ImportError:  # pragma: no cover - exercised only where numba is missing
    point_max, load_point = _point_max_py, _load_point_py
else:

    @njit(cache=True, nogil=True, inline="always")
    def point_max(x0, pi0, bound):  # pragma: no cover - compiled; same as _point_max_py
        """``max |pi0|`` when every entry of the 1-D ``x0``, ``pi0`` (the same length) is finite with
        ``|v| <= bound``, else -1.0 (NaN fails every comparison). Inlined into its callers."""
        pmax = 0.0
        for i in range(x0.shape[0]):
            v, w = abs(x0[i]), abs(pi0[i])
            if not (v <= bound and w <= bound):
                return -1.0
            if w > pmax:
                pmax = w
        return pmax

    @njit(cache=True, nogil=True)
    def load_point(x0, pi0, X, P, bound):  # pragma: no cover - compiled; same as _load_point_py
        """One trajectory's start: :func:`point_max`, and where that is not -1.0, ``x0``, ``pi0``
        copied into the columns ``X[:, 0]``, ``P[:, 0]``."""
        pmax = point_max(x0, pi0, bound)
        if pmax >= 0.0:
            for i in range(x0.shape[0]):
                X[i, 0] = x0[i]
                P[i, 0] = pi0[i]
        return pmax


def admitted(pmax: float, pi0, t, limits) -> bool:
    """Whether one trajectory's start, read by a runner's compiled loader (:func:`load_point`, the
    su(2) runner's ``_load_start``: ``pmax = max |pi0|``, or -1.0), goes on: False where an entry is
    not finite or beyond the bound (the general route then refuses it by name, issue 30); else after
    the caller's rates check ``rates(pi0, t, pmax)`` of ``limits = (free, rates)``, run only where
    ``pmax > free`` (below ``free`` it passes at every ``t``). One rule for every runner."""
    if pmax < 0.0:
        return False
    if not pmax <= limits[0]:
        limits[1](pi0, t, pmax)
    return True


def check_finite(x, pi, tv: float) -> None:
    """Trajectories (columns of ``x``, ``pi`` (n, N)) not finite at ``tv`` are refused, by index (the
    flows' last check, :func:`refimpl.flows.fast_flow`)."""
    bad_pi = ~np.all(np.isfinite(pi), axis=0)
    if np.any(bad_pi):
        raise ValueError(
            f"fast_flow: trajectories {np.flatnonzero(bad_pi)[:10].tolist()} became non-finite before t = {tv} "
            "(they reached the degenerate set Pi_1, vier12, or diverged); no point is dropped"
        )
    bad = ~np.all(np.isfinite(x), axis=0)
    if np.any(bad):
        raise ValueError(
            f"fast_flow: no logarithm x(t) of g(t) found for trajectories {np.flatnonzero(bad)[:10].tolist()}"
        )


def finite_one(x, pi, tv: float):
    """``(x, pi)`` of one trajectory (1-D) when every entry is finite (a finite sum: every entry is),
    else :func:`check_finite`'s refusal."""
    if not math.isfinite(sum(x.tolist()) + sum(pi.tolist())):
        check_finite(x.reshape(-1, 1), pi.reshape(-1, 1), tv)
    return x, pi
