"""The compiled adaptive Taylor method for the rational body fields (``Upsilon != 0``): the solve by
``Phi`` as a series recurrence, one inverse of ``Phi_0`` per step (:mod:`refimpl._compiled_rational`)."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Method

__all__ = ["INTEGRATORS", "RationalTaylorMethod"]


@dataclass(frozen=True)
class RationalTaylorMethod(Method):
    """Adaptive order and step from a tolerance (Jorba-Zou) on the body system ``(pi[, Gamma])`` with
    ``Upsilon != 0``; raises :class:`refimpl._errors.DegeneratePointError` on the degenerate set."""

    kind: str = "taylor-rational"
    adaptive: bool = True

    def applies(self, model) -> tuple[bool, str]:
        if model.upsilon_zero:
            return (
                False,
                "Upsilon = 0: the field is polynomial and the method 'taylor' needs no Phi solve",
            )
        return True, "body system only (pi, Gamma); no configuration"


INTEGRATORS = [RationalTaylorMethod("taylor-rational", 0)]
