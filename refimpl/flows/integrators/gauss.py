"""Gauss-Legendre collocation (orders 2, 4, 6): implicit, symplectic, for general omega_L
(``Upsilon != 0``); the stage equations solved by fixed-point iteration to rounding."""

from __future__ import annotations

from ..._integrators import GaussLegendre
from .._common import body_numpy, full_rebased, gamma0
from ..base import FixedStep, FlowResult

__all__ = ["INTEGRATORS", "GaussIntegrator"]


class GaussIntegrator(FixedStep):
    """``s``-stage Gauss-Legendre (order ``2s``) on the body system or the re-based full state."""

    def __init__(self, name: str, stages: int, *, rank: float = 1000.0):
        self.stepper = GaussLegendre(stages)
        super().__init__(name, self.stepper.order, rank=rank)

    def _run(self, model, x0, pi0, t, *, steps, system, observe) -> FlowResult:
        if system == "body":
            return body_numpy(model, self.stepper, pi0, gamma0(model, x0), t, steps, observe)
        return full_rebased(model, self.stepper, x0, pi0, t, steps, rkmk=False, observe=observe)


INTEGRATORS = [
    GaussIntegrator("midpoint", 1, rank=20),
    GaussIntegrator("gauss4", 2, rank=21),
    GaussIntegrator("gauss6", 3, rank=22),
]
