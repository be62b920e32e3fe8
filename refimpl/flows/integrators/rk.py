"""Explicit Runge-Kutta methods on the batched numpy field: DOP853's tableau (order 8), the classical
RK4, and their RKMK variants (Munthe-Kaas: re-based after every step). Any ``Upsilon``."""

from __future__ import annotations

from ..._integrators import DOP853, RK4, ExplicitRK
from .._common import body_numpy, full_rebased, gamma0
from ..base import FixedStep, FlowResult

__all__ = ["INTEGRATORS", "ExplicitRKIntegrator"]


class ExplicitRKIntegrator(FixedStep):
    """Fixed-step explicit RK (:class:`refimpl._integrators.ExplicitRK`) on the body system or the full
    state with re-basing; with ``Upsilon = 0`` the body field is generated straight-line code."""

    def __init__(self, name: str, stepper: ExplicitRK, *, rkmk: bool = False, rank: float = 1000.0):
        super().__init__(name, stepper.order, rank=rank)
        self.stepper, self.rkmk = stepper, rkmk

    def applies(self, model):
        if not model.upsilon_zero:
            return (
                True,
                "explicit RK is not symplectic for omega_L; a Gauss method keeps the structure",
            )
        return True, ""

    def _run(self, model, x0, pi0, t, *, steps, system, observe) -> FlowResult:
        if system == "body":
            return body_numpy(model, self.stepper, pi0, gamma0(model, x0), t, steps, observe)
        return full_rebased(model, self.stepper, x0, pi0, t, steps, rkmk=self.rkmk, observe=observe)


INTEGRATORS = [
    ExplicitRKIntegrator("dop853", DOP853, rank=10),
    ExplicitRKIntegrator("rk4", RK4, rank=12),
    ExplicitRKIntegrator("rkmk4", RK4, rkmk=True, rank=13),
    ExplicitRKIntegrator("rkmk8", DOP853, rkmk=True, rank=14),
]
