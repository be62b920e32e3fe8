"""The outcome of a claim check and the error model of the mpmath first-principles route."""

from __future__ import annotations

from dataclasses import dataclass

import mpmath

DPS = 30


@dataclass
class Outcome:
    """``ok``: the claim as stated holds; ``error``/``tolerance``: the measured defect and its bound."""

    ok: bool
    error: float | None = None
    tolerance: float | None = None
    detail: str = ""


def tolerance(scale=1) -> mpmath.mpf:
    # error model for the mpmath first-principles route: mpmath.diff at DPS + 15 guard digits
    # is good to ~DPS digits; we ask for DPS - 8 correct digits of the scale.
    return mpmath.mpf(10) ** (-(DPS - 8)) * max(mpmath.mpf(1), abs(scale))


def within(err, detail: str) -> Outcome:
    """The outcome of an mpmath check whose defect ``err`` is held to :func:`tolerance` (scale 1)."""
    tol = tolerance()
    return Outcome(bool(err <= tol), float(err), float(tol), detail)
