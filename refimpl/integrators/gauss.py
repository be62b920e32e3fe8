"""Gauss-Legendre collocation (orders 2, 4, 6): implicit, symplectic, for general omega_L (Upsilon != 0)."""

from __future__ import annotations

from dataclasses import dataclass

from .._integrators import GaussLegendre
from .base import Method

__all__ = ["INTEGRATORS", "GaussMethod"]


@dataclass(frozen=True)
class GaussMethod(Method):
    kind: str = "gauss"


INTEGRATORS = [
    GaussMethod("midpoint", 2, stepper=GaussLegendre(1)),
    GaussMethod("gauss4", 4, stepper=GaussLegendre(2)),
    GaussMethod("gauss6", 6, stepper=GaussLegendre(3)),
]
