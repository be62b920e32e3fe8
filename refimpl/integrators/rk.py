"""Explicit Runge-Kutta methods (DOP853 tableau order 8, classical RK4) and their RKMK variants."""

from __future__ import annotations

from dataclasses import dataclass

from .._integrators import DOP853, RK4
from .base import Method

__all__ = ["INTEGRATORS", "ExplicitRKMethod", "ScalarRKMethod"]


@dataclass(frozen=True)
class ExplicitRKMethod(Method):
    """Fixed-step explicit RK on the batched numpy field (any ``Upsilon``; ``rkmk``: re-based every step)."""

    kind: str = "rk"

    def applies(self, model) -> tuple[bool, str]:
        if not model.upsilon_zero:
            return (
                True,
                "explicit RK is not symplectic for omega_L; a Gauss method keeps the structure",
            )
        return True, ""


@dataclass(frozen=True)
class ScalarRKMethod(Method):
    """The DOP853 tableau unrolled around the generated straight-line body field (one trajectory)."""

    kind: str = "scalar"

    def applies(self, model) -> tuple[bool, str]:
        if not model.upsilon_zero:
            return (
                False,
                "the generated scalar code covers the polynomial body system (Upsilon = 0)",
            )
        return True, ""


INTEGRATORS = [
    ExplicitRKMethod("dop853", 8, stepper=DOP853),
    ScalarRKMethod("dop853-scalar", 8, stepper=DOP853),
    ExplicitRKMethod("rk4", 4, stepper=RK4),
    ExplicitRKMethod("rkmk4", 4, rkmk=True, stepper=RK4),
    ExplicitRKMethod("rkmk8", 8, rkmk=True, stepper=DOP853),
]
