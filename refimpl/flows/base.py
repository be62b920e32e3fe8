"""The integrator interface of the fast flows: :class:`Integrator`, its typed :class:`FlowResult`.

An integrator is one class in one file of :mod:`refimpl.flows.integrators` (discovered there by
:mod:`refimpl.flows.registry`; nothing else to edit). Its contract, for a third party too:

1. Subclass :class:`FixedStep` (a step count ``steps``) or :class:`Adaptive` (a tolerance ``tol``);
   declare ``order`` (the global order a fixed-step method is fitted to by
   ``tests/test_flow_orders.py``; 0 for adaptive methods, whose order follows ``tol``).
2. Implement :meth:`Integrator.applies` ``(model) -> (ok, why)``: where the method integrates a
   :class:`refimpl.model.Model` (``why``: a note when it does, the reason when it does not).
3. Implement ``_run(model, x0, pi0, t, *, steps | tol, system, observe) -> FlowResult``: ``x0``, ``pi0``
   components-first ``(n, N)``, never written; ``system`` ``"body"`` (``pi[, Gamma]``, no
   configuration) or ``"full"`` (``x``, ``pi``); ``observe(k, pi, Gamma, x)`` after step ``k``
   (fixed-step methods). The checks shared by every method (applies, tolerance, step count) are done
   by :meth:`Integrator.integrate` before ``_run`` is called.
4. List the instances in the module's ``INTEGRATORS`` (each with a unique ``name``; ``rank`` orders
   the registry, default after the existing ones).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, fields

import numpy as np

from ..model import Model, State

__all__ = ["Adaptive", "FixedStep", "FlowResult", "Integrator", "check_tolerance"]


def check_tolerance(tol) -> float:
    """``tol`` as a finite float > 0, else ``ValueError`` naming it."""
    try:
        v = float(tol)
    except (TypeError, ValueError):
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}") from None
    if not math.isfinite(v) or v <= 0:  # math: a Python float (np.isfinite costs ~0.7 us per call)
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}")
    return v


@dataclass
class FlowResult:
    """What an integrator returns: components-first arrays ``(d, N)`` per trajectory.

    ``pi``; ``Gamma`` (``Ad(g)^T gamma``, with gravity); ``x`` (the logarithm of ``g``, full state);
    ``g`` (``g`` in the algebra's faithful representation, ``(N, r, r)``, when the method tracks it);
    ``quat`` (su(2): the unit quaternion of ``g``, ``(4, N)``); ``Ad`` (``Ad(g)``, ``(N, n, n)``) and
    ``Ad_ref``, ``x_local`` (the re-based chart: ``g = g_ref exp(x_local)``); ``rebases`` per trajectory;
    ``steps`` per trajectory; ``error_estimate`` (the two-run control's, per trajectory);
    ``cond_phi`` (largest ``cond(Psi_0)`` seen, rational Taylor); ``path`` (``numba``/``python``
    for the compiled methods). Item access ``result["pi"]`` and ``"x" in result`` (set, not None) read the same fields.
    """

    pi: np.ndarray
    Gamma: np.ndarray | None = None
    x: np.ndarray | None = None
    Ad: np.ndarray | None = None
    quat: np.ndarray | None = None
    g: np.ndarray | None = None
    rebases: np.ndarray | None = None
    steps: np.ndarray | None = None
    error_estimate: np.ndarray | None = None
    cond_phi: np.ndarray | None = None
    x_local: np.ndarray | None = None
    Ad_ref: np.ndarray | None = None
    path: str | None = None

    def __getitem__(self, key: str):
        if key not in _FIELDS:
            raise KeyError(key)
        return getattr(self, key)

    def __contains__(self, key: str) -> bool:
        return key in _FIELDS and getattr(self, key) is not None

    def get(self, key: str, default=None):
        value = getattr(self, key, None) if key in _FIELDS else None
        return default if value is None else value


_FIELDS = frozenset(f.name for f in fields(FlowResult))


class Integrator(ABC):
    """A fast flow method (abstract; the contract is in the module docstring)."""

    adaptive: bool = False
    rkmk: bool = False  # Munthe-Kaas re-basing after every step (explicit RK family only)

    def __init__(self, name: str, order: int, *, rank: float = 1000.0):
        self.name, self.order, self.rank = name, int(order), float(rank)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, order={self.order})"

    def applies(self, model: Model) -> tuple[bool, str]:
        """``(True, note)`` when the method integrates ``model``, else ``(False, why)``."""
        return True, ""

    def integrate(
        self,
        model: Model,
        state: State,
        t: float,
        *,
        tol: float | None = None,
        steps: int | None = None,
        system: str = "full",
        observe=None,
    ) -> FlowResult:
        """The flow of ``state`` (``x``, ``pi`` components-first ``(n, N)``) over the time ``t``."""
        ok, why = self.applies(model)
        if not ok:
            raise ValueError(f"method {self.name} does not apply: {why}")
        if system not in ("body", "full"):
            raise ValueError(f"system must be 'body' or 'full', got {system!r}")
        return self._checked_run(model, state.x, state.pi, t, tol, steps, system, observe)

    @abstractmethod
    def _checked_run(self, model, x0, pi0, t, tol, steps, system, observe) -> FlowResult: ...


class FixedStep(Integrator):
    """A method taking ``steps`` equal steps (its error ``O(h^order)``)."""

    def _checked_run(self, model, x0, pi0, t, tol, steps, system, observe):
        if steps is None:
            raise ValueError(f"method {self.name} takes a step count: give steps, not tol")
        return self._run(model, x0, pi0, t, steps=int(steps), system=system, observe=observe)

    @abstractmethod
    def _run(self, model, x0, pi0, t, *, steps: int, system: str, observe) -> FlowResult: ...


class Adaptive(Integrator):
    """A method choosing its steps (and order) per trajectory from a tolerance ``tol``."""

    adaptive = True

    def _checked_run(self, model, x0, pi0, t, tol, steps, system, observe):
        if tol is None:
            raise ValueError(
                f"method {self.name} is adaptive: give tol (a tolerance), not a step count"
            )
        tol = check_tolerance(tol)
        if observe is not None:
            raise ValueError(f"method {self.name} is adaptive: it has no fixed steps to observe")
        return self._run(model, x0, pi0, t, tol=tol, system=system)

    @abstractmethod
    def _run(self, model, x0, pi0, t, *, tol: float, system: str) -> FlowResult: ...
