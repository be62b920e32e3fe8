"""The base class of the fast flow methods: a name, a declared order, a kind, and where it applies."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Method"]


@dataclass(frozen=True)
class Method:
    """A fast flow method.

    ``order``: the declared global order (``tests/test_flow_orders.py`` fits it); ``0`` for the adaptive
    methods, whose order follows the tolerance. ``kind`` selects the integration path of
    :func:`refimpl._flow_fast.integrate_fast` (``rk``, ``gauss``, ``scalar``, ``taylor``,
    ``taylor-adaptive``, ``splitting``); ``rkmk``: Munthe-Kaas re-basing after every step;
    ``stepper``: the :mod:`refimpl._integrators` object of the rk and gauss kinds.
    """

    name: str
    order: int
    kind: str
    rkmk: bool = False
    stepper: object = None
    adaptive: bool = False

    def applies(self, model) -> tuple[bool, str]:
        """``(True, note)`` when the method integrates ``model`` (a :class:`refimpl._flow_fast.NumpyModel`),
        else ``(False, why)``."""
        return True, ""
