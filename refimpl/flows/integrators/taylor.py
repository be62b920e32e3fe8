"""Taylor-series methods of fixed order 12-24 for the polynomial body systems (``Upsilon = 0``):
Cauchy-product recurrences for the Taylor coefficients of the quadratic field (:mod:`refimpl._taylor`).

The compiled kernel of :mod:`refimpl._compiled_taylor` when numba is importable and no step is
observed; else generated scalar code for up to :data:`TAYLOR_SCALAR_MAX` trajectories and batched
numpy ``einsum`` kernels beyond.
"""

from __future__ import annotations

import numpy as np

from ... import _compiled_taylor as _ct
from ..._flow_compiled import compiled_taylor_body
from ..._taylor import numpy_taylor_integrator, scalar_taylor_integrator
from .._common import body_observer, body_scalar, gamma0
from ..base import FixedStep, FlowResult

__all__ = ["INTEGRATORS", "TAYLOR_SCALAR_MAX", "TaylorIntegrator"]

TAYLOR_SCALAR_MAX = (
    16  # up to this many trajectories the Taylor methods run generated scalar code: the
)
# numpy kernel's fixed cost per step (~20 calls per order) matched the scalar code's between 16 and 32
# heavy tops

_NEEDS = "the Taylor recurrences need the quadratic polynomial body system (Upsilon = 0)"


class TaylorIntegrator(FixedStep):
    """Fixed order and step on the body system (no configuration)."""

    def applies(self, model):
        return (False, _NEEDS) if not model.upsilon_zero else (True, "")

    def _run(self, model, x0, pi0, t, *, steps, system, observe) -> FlowResult:
        if system == "body" and observe is None and _ct.HAVE_NUMBA:
            return FlowResult(
                **compiled_taylor_body(model, x0, pi0, t, order=self.order, nsteps=steps)
            )
        if system != "body":
            raise ValueError(f"method {self.name} integrates body systems only (no configuration)")
        n, N = pi0.shape
        G0 = gamma0(model, x0)
        h = t / steps
        if N <= TAYLOR_SCALAR_MAX:
            run = scalar_taylor_integrator(model, self.order)
            return body_scalar(model, run, pi0, G0, h, steps, observe)
        y0 = pi0 if G0 is None else np.concatenate([pi0, G0])
        obs = body_observer(observe, n, G0)
        y = numpy_taylor_integrator(model, self.order)(y0, h, steps, observe=obs)
        return FlowResult(
            pi=y[:n], Gamma=None if G0 is None else y[n:], rebases=np.zeros(N, dtype=int)
        )


INTEGRATORS = [TaylorIntegrator(f"taylor{P}", P, rank=30 + P / 100) for P in (12, 16, 20, 24)]
