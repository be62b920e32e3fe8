"""The checks of a flow request shared by the fast and the reference flows: the time span.

Plain floats and ints are checked here directly; exact inputs (``Fraction``, ``"1/2"``, mpf, sympy) go
through the project's exact reader (:func:`refimpl._reference_core._to_mpf`) and are rounded once."""

from __future__ import annotations

import math

import mpmath
import numpy as np

from ._reference_core import _to_mpf

__all__ = ["check_time"]

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
