"""The compiled adaptive Taylor method for the polynomial body systems (``Upsilon = 0``): Jorba-Zou
order and step from a tolerance, per trajectory (:mod:`refimpl._compiled_taylor`); on su(2)/so(3) the
full state carries the group element as a quaternion under the two-run control of
:mod:`refimpl._flow_compiled`; on every other algebra the full state carries ``G = rho(g)`` in the
faithful representation (:mod:`refimpl._full_state`, a kernel generated per structure)."""

from __future__ import annotations

from ... import _full_state
from ..._flow_compiled import compiled_taylor_body, compiled_taylor_flow, supports_full
from .._common import _AbelianPart
from ..base import Adaptive, FlowResult

__all__ = ["INTEGRATORS", "AdaptiveTaylor"]


class AdaptiveTaylor(Adaptive):
    """Body system at the *local* tolerance ``tol``; the su(2) full state at the global one."""

    def applies(self, model):
        if not model.upsilon_zero:
            return (
                False,
                "the Taylor recurrences need the quadratic polynomial body system (Upsilon = 0)",
            )
        return True, ""

    def _run(self, model, x0, pi0, t, *, tol, system) -> FlowResult:
        if system == "body":
            return FlowResult(**compiled_taylor_body(model, x0, pi0, t, tol=tol))
        if _full_state.applies(model):  # any other algebra: G = rho(g) in the quadratic state
            return FlowResult(
                **_full_state.full_state_flow(model, x0, pi0, t, tol, abelian=_AbelianPart)
            )
        if not supports_full(model):
            raise ValueError(
                f"method {self.name} integrates the full state on su(2)/so(3) only; "
                "use system='body' or a re-basing method"
            )
        return FlowResult(**compiled_taylor_flow(model, x0, pi0, t, tol))


INTEGRATORS = [AdaptiveTaylor("taylor", 0, rank=40)]
