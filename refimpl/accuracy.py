"""Agreement measured as in docs/conventions.md: the one max-abs / correct-digits helper of the house.

``correct digits = -log10(max|approx - ref| / max(max|ref|, floor))``, computed in mpmath at a
precision high enough that the comparison itself does not round. Every value is converted
exactly (floats are binary fractions, ints, ``Fraction``, decimal strings, mpmath and sympy
numbers). No NaN passes: a NaN or an infinity on either side makes the difference infinite, so
the digits are ``-inf`` and any ratio built on it fails.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import mpmath
import numpy as np
import sympy

__all__ = ["to_mpf", "max_abs", "max_abs_diff", "correct_digits", "digits_of_agreement"]


def to_mpf(v: Any) -> mpmath.mpf:
    """One real number as an mpmath number at the current precision (complex is refused)."""
    if isinstance(v, mpmath.mpf):
        return v
    if isinstance(v, Fraction):
        return mpmath.mpf(v.numerator) / v.denominator
    if isinstance(v, (bool, int, float, str, np.floating, np.integer)):
        return mpmath.mpf(v if not isinstance(v, (np.floating, np.integer)) else v.item())
    if isinstance(v, (complex, np.complexfloating, mpmath.mpc)):
        raise TypeError(f"expected a real number, got the complex value {v!r}")
    try:  # sympy numbers and other objects that mpmath understands
        if isinstance(v, sympy.Basic):
            return mpmath.mpf(sympy.N(v, mpmath.mp.dps + 5))
    except ImportError:  # pragma: no cover - sympy is a dependency
        pass
    return mpmath.mpf(v)


def _flat(a) -> list:
    if isinstance(a, mpmath.matrix):
        return [a[i, j] for i in range(a.rows) for j in range(a.cols)]
    return list(np.asarray(a, dtype=object).ravel())


def max_abs(values, *, dps: int = 50) -> mpmath.mpf:
    """``max |v|`` over ``values`` (0 for none); ``inf`` if any value is NaN or infinite."""
    with mpmath.workdps(dps):
        out = mpmath.mpf(0)
        for v in _flat(values):
            m = to_mpf(v)
            if not mpmath.isfinite(m):
                return mpmath.inf
            out = max(out, abs(m))
        return +out


def max_abs_diff(a, b, *, dps: int = 200) -> tuple[mpmath.mpf, mpmath.mpf]:
    """``(max|a - b|, max(max|b|, 1))`` at ``dps`` digits; the difference is ``inf`` when a NaN or an
    infinity appears on either side, or when the shapes differ."""
    A, B = _flat(a), _flat(b)
    with mpmath.workdps(dps):
        if len(A) != len(B):
            return mpmath.inf, mpmath.mpf(1)
        diff, scale = mpmath.mpf(0), mpmath.mpf(1)
        for x, y in zip(A, B):
            xm, ym = to_mpf(x), to_mpf(y)
            if not (mpmath.isfinite(xm) and mpmath.isfinite(ym)):
                return mpmath.inf, max(scale, abs(ym) if mpmath.isfinite(ym) else scale)
            diff = max(diff, abs(xm - ym))
            scale = max(scale, abs(ym))
        return diff, scale


def correct_digits(diff, scale=1) -> float:
    """``-log10(diff / max(scale, 1))``: ``inf`` for an exact match, ``-inf`` for NaN or infinite ``diff``."""
    with mpmath.workdps(50):
        d, s = to_mpf(diff), to_mpf(scale)
        if not mpmath.isfinite(d) or not mpmath.isfinite(s):
            return -math.inf
        if d == 0:
            return math.inf
        return float(-mpmath.log10(d / max(s, mpmath.mpf(1))))


def digits_of_agreement(approx, ref, *, dps: int = 200) -> float:
    """Correct significant digits of ``approx`` against ``ref`` in the max norm."""
    return correct_digits(*max_abs_diff(approx, ref, dps=dps))
