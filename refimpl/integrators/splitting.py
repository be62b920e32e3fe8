"""Lie-Poisson splitting for su(2)/so(3) (Strang, raised by the triple jump to orders 4 and 6)."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Method

__all__ = ["INTEGRATORS", "SplittingMethod"]


@dataclass(frozen=True)
class SplittingMethod(Method):
    kind: str = "splitting"

    def applies(self, model) -> tuple[bool, str]:
        if not model.su2:
            return False, "Lie-Poisson splitting is written for su(2)/so(3) only"
        if not model.upsilon_zero:
            return False, "Lie-Poisson splitting needs Upsilon = 0"
        if not model.I_diagonal:
            return False, "Lie-Poisson splitting needs a diagonal inertia (principal axes)"
        return True, ""


INTEGRATORS = [
    SplittingMethod("splitting2", 2),
    SplittingMethod("splitting4", 4),
    SplittingMethod("splitting6", 6),
]
