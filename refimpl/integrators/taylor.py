"""Taylor-series methods for the polynomial body systems (Upsilon = 0): fixed orders 12-24, and the
adaptive compiled method (Jorba-Zou order and step from the tolerance, :mod:`refimpl._compiled_taylor`)."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Method

__all__ = ["INTEGRATORS", "AdaptiveTaylorMethod", "TaylorMethod"]

_NEEDS = "the Taylor recurrences need the quadratic polynomial body system (Upsilon = 0)"


@dataclass(frozen=True)
class TaylorMethod(Method):
    """Fixed order and step (compiled kernel with numba; generated Python/numpy code without)."""

    kind: str = "taylor"

    def applies(self, model) -> tuple[bool, str]:
        return (False, _NEEDS) if not model.upsilon_zero else (True, "")


@dataclass(frozen=True)
class AdaptiveTaylorMethod(Method):
    """Adaptive order and step from a tolerance; full state (configuration as a quaternion) on su(2)."""

    kind: str = "taylor-adaptive"
    adaptive: bool = True

    def applies(self, model) -> tuple[bool, str]:
        return (False, _NEEDS) if not model.upsilon_zero else (True, "")


INTEGRATORS = [
    TaylorMethod("taylor12", 12),
    TaylorMethod("taylor16", 16),
    TaylorMethod("taylor20", 20),
    TaylorMethod("taylor24", 24),
    AdaptiveTaylorMethod("taylor", 0),
]
