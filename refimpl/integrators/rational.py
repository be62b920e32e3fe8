"""The compiled adaptive Taylor method for the rational body fields (``Upsilon != 0``): the solve by
``Phi`` as a series recurrence, one inverse of ``Phi_0`` per step (:mod:`refimpl._compiled_rational`)."""

from __future__ import annotations

from dataclasses import dataclass

from .base import Method

__all__ = ["INTEGRATORS", "RationalTaylorMethod"]


@dataclass(frozen=True)
class RationalTaylorMethod(Method):
    """Adaptive order and step from a tolerance (Jorba-Zou) on the body system ``(pi[, Gamma])`` with
    ``Upsilon != 0``, and on su(2)/so(3) the full state ``(pi, [Gamma,] q)`` under the two-run control
    of :mod:`refimpl._flow_compiled`; raises :class:`refimpl._errors.DegeneratePointError` on the
    degenerate set."""

    kind: str = "taylor-rational"
    adaptive: bool = True

    def applies(self, model) -> tuple[bool, str]:
        if model.upsilon_zero:
            return (
                False,
                "Upsilon = 0: the field is polynomial and the method 'taylor' needs no Phi solve",
            )
        if not model.su2:
            return (
                True,
                "body system (pi, Gamma) on this algebra; the full state on su(2)/so(3) only",
            )
        return True, "body system (pi, Gamma), and the full state with the quaternion (su(2)/so(3))"


INTEGRATORS = [RationalTaylorMethod("taylor-rational", 0)]
