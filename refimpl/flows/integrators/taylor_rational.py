"""The compiled adaptive Taylor method for the rational body fields (``Upsilon != 0``): the solve by
``Phi`` as a series recurrence, one inverse of ``Phi_0`` per step (:mod:`refimpl._compiled_rational`)."""

from __future__ import annotations

from ..._compiled_rational import rational_taylor_body
from ..._flow_compiled import compiled_taylor_flow
from ..base import Adaptive, FlowResult

__all__ = ["INTEGRATORS", "RationalTaylor"]


class RationalTaylor(Adaptive):
    """Adaptive order and step from a tolerance (Jorba-Zou) on the body system ``(pi[, Gamma])`` with
    ``Upsilon != 0``, and on su(2)/so(3) the full state ``(pi, [Gamma,] q)`` under the two-run control
    of :mod:`refimpl._flow_compiled`; raises :class:`refimpl._errors.DegeneratePointError` on the
    degenerate set."""

    def applies(self, model):
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

    def _run(self, model, x0, pi0, t, *, tol, system) -> FlowResult:
        if system == "body":
            return FlowResult(**rational_taylor_body(model, x0, pi0, t, tol=tol))
        if not model.su2:
            raise ValueError(
                f"method {self.name} integrates the full state on su(2)/so(3) only (the "
                "configuration as a quaternion); use system='body' or a re-basing method"
            )
        return FlowResult(**compiled_taylor_flow(model, x0, pi0, t, tol))


INTEGRATORS = [RationalTaylor("taylor-rational", 0, rank=60)]
