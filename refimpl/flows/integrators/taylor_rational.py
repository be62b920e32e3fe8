"""The compiled adaptive Taylor method for the rational body fields (``Upsilon != 0``): the solve by
``Phi`` as a series recurrence, one inverse of ``Phi_0`` per step (:mod:`refimpl._compiled_rational`)."""

from __future__ import annotations

from ... import _full_state_rational
from ..._compiled_rational import rational_taylor_body
from ..._flow_compiled import compiled_taylor_flow
from .._common import _AbelianPart
from ..base import Adaptive, FlowResult

__all__ = ["INTEGRATORS", "RationalTaylor"]


class RationalTaylor(Adaptive):
    """Adaptive order and step from a tolerance (Jorba-Zou) on the body system ``(pi[, Gamma])`` with
    ``Upsilon != 0``; the full state on su(2)/so(3) as ``(pi, [Gamma,] q)`` under the two-run control
    of :mod:`refimpl._flow_compiled`, on every other algebra as ``(pi, [Gamma,] G = rho(g))`` under
    that of :mod:`refimpl._full_state` (:mod:`refimpl._full_state_rational`); raises
    :class:`refimpl._errors.DegeneratePointError` on the degenerate set."""

    def applies(self, model):
        if model.upsilon_zero:
            return (
                False,
                "Upsilon = 0: the field is polynomial and the method 'taylor' needs no Phi solve",
            )
        if not model.su2:
            if _full_state_rational.applies(model):
                return True, "body system (pi, Gamma), and the full state with G = rho(g)"
            return True, "body system (pi, Gamma); the full state needs numba off su(2)/so(3)"
        return True, "body system (pi, Gamma), and the full state with the quaternion (su(2)/so(3))"

    def _run(self, model, x0, pi0, t, *, tol, system) -> FlowResult:
        if system == "body":
            return FlowResult(**rational_taylor_body(model, x0, pi0, t, tol=tol))
        if _full_state_rational.applies(model):  # G = rho(g) in the faithful representation
            return FlowResult(
                **_full_state_rational.rational_full_state_flow(
                    model, x0, pi0, t, tol, abelian=_AbelianPart
                )
            )
        if not model.su2:
            raise ValueError(
                f"method {self.name} integrates the full state off su(2)/so(3) only with numba "
                "(G = rho(g)); use system='body' or a re-basing method"
            )
        return FlowResult(**compiled_taylor_flow(model, x0, pi0, t, tol))


INTEGRATORS = [RationalTaylor("taylor-rational", 0, rank=60)]
