"""DOP853's tableau unrolled around the generated straight-line body field: one trajectory at a time
in Python floats (``Upsilon = 0``; :func:`refimpl.codegen.scalar_rk`)."""

from __future__ import annotations

import numpy as np

from ... import codegen
from ..._integrators import DOP853
from ..._lru import LRU
from .._common import body_scalar, gamma0
from ..base import FixedStep, FlowResult

__all__ = ["INTEGRATORS", "ScalarRK", "scalar_rk_integrator"]

_SCALAR_RK = LRU(64)  # generated scalar RK functions, keyed on the numbers


def scalar_rk_integrator(model, tableau):
    """``run(y0: list, h, nsteps, observe=None) -> list`` for one trajectory: the explicit RK ``tableau``
    unrolled around the generated body field (:func:`refimpl.codegen.scalar_rk`)."""
    key = (
        model.f.tobytes(),
        model.theta.tobytes(),
        model.Iinv.tobytes(),
        None if not model.gravity else model.Lvec.tobytes(),
        np.asarray(tableau[0]).tobytes(),
    )
    return _SCALAR_RK.get(key, lambda: codegen.scalar_rk(model.quadratic_field, tableau))


class ScalarRK(FixedStep):
    """The RK method of ``tableau`` as generated scalar code (body systems, ``Upsilon = 0``)."""

    def __init__(self, name: str, stepper, *, rank: float = 1000.0):
        super().__init__(name, stepper.order, rank=rank)
        self.stepper = stepper

    def applies(self, model):
        if not model.upsilon_zero:
            return (
                False,
                "the generated scalar code covers the polynomial body system (Upsilon = 0)",
            )
        return True, ""

    def _run(self, model, x0, pi0, t, *, steps, system, observe) -> FlowResult:
        if system != "body":
            raise ValueError(f"method {self.name} integrates body systems only (no configuration)")
        s = self.stepper
        run = scalar_rk_integrator(model, (s.A, s.b, s.c))
        return body_scalar(model, run, pi0, gamma0(model, x0), t / steps, steps, observe)


INTEGRATORS = [ScalarRK("dop853-scalar", DOP853, rank=11)]
