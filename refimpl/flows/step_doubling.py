"""Step doubling: a fixed-step integrator wrapped into one that meets a tolerance.

The steps are doubled from ``8 + 4 ceil(|t|)`` until the runs with ``N`` and ``2N`` steps differ by at
most ``tol (2^p - 1)`` on every trajectory (``p`` the wrapped method's order; Richardson: the error of
the finer run is then below ``tol``), over ``pi`` and ``Ad(g)`` (or ``x`` where ``Ad`` is not formed).
A run that diverges (an implicit stage iteration, a stage carried onto a singular Phi) is discarded
and the steps doubled again; three such runs name the degenerate set.
"""

from __future__ import annotations

import numpy as np

from .._validate import StepBudget
from .base import Adaptive, FixedStep, FlowResult

__all__ = ["StepDoubling"]

MAX_DOUBLINGS = 14


def _xdiff(a: FlowResult, b: FlowResult):
    if a.Ad is not None:
        return (a.Ad - b.Ad).reshape(a.Ad.shape[0], -1).T
    return a.x - b.x


class StepDoubling(Adaptive):
    """``inner`` (a :class:`refimpl.flows.base.FixedStep`) run at doubling step counts until two runs
    agree to ``tol (2^order - 1)`` on every trajectory (module docstring)."""

    def __init__(self, inner: FixedStep, budget: StepBudget | None = None):
        if inner.adaptive:
            raise ValueError(f"StepDoubling wraps a fixed-step method, got {inner.name}")
        super().__init__(inner.name, inner.order, rank=inner.rank)
        self.inner = inner
        self.budget = budget  # every run is estimated before it starts (refimpl._validate)

    def applies(self, model):
        return self.inner.applies(model)

    def _run(self, model, x0, pi0, t, *, tol, system) -> FlowResult:
        inner, order = self.inner, self.inner.order
        N = int(8 + 4 * np.ceil(abs(t)))
        budget = self.budget if self.budget is not None else StepBudget("fast_flow")
        doing = f"{inner.name} on {x0.shape[1]} trajectories to t = {t:g}"

        def run(N):
            # too coarse a step can make an implicit stage iteration diverge, or carry a stage
            # onto a singular Phi: that run is discarded (None) and the steps doubled again
            started = budget.before(N, doing)
            try:
                with np.errstate(all="ignore"):
                    res = inner._run(model, x0, pi0, t, steps=N, system=system, observe=None)
            except (np.linalg.LinAlgError, FloatingPointError):
                return None
            finally:
                budget.after(N, started)
            return res if np.all(np.isfinite(res.pi)) else None

        budget.before(3 * N, f"the step doubling's first two runs ({N} and {2 * N} steps)")
        prev, failed = run(N), 0
        for _ in range(MAX_DOUBLINGS):
            N *= 2
            out = run(N)
            if out is None or prev is None:
                failed += out is None
                if failed >= 3:  # a regular trajectory stops failing once the steps are fine
                    raise ValueError(
                        f"fast_flow: {failed} runs (up to {N} steps) diverged or met a singular "
                        f"Phi before t = {t}: the trajectory reaches or grazes the degenerate set "
                        "Pi_1 (vier12)"
                    )
                prev = out
                continue
            diff = np.max(np.abs(np.concatenate([out.pi - prev.pi, _xdiff(out, prev)])), axis=0)
            if np.all(diff <= tol * (2**order - 1)):
                return out
            prev = out
        why = (
            f" ({failed} runs diverged or met a singular Phi: the trajectory may reach the "
            "degenerate set Pi_1, vier12)"
            if failed
            else ""
        )
        raise ValueError(f"fast_flow: tolerance {tol} not reached with {N} steps{why}")
