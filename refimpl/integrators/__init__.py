"""The registry of the fast flow methods: one module per family, each listing its ``INTEGRATORS``.

Every method is a :class:`~refimpl.integrators.base.Method` subclass instance declaring ``order``,
``kind`` and ``applies(model)``. Adding an integrator: one new family module with an ``INTEGRATORS``
list (or one more entry in an existing family), plus its name in :data:`FAMILIES` below.
"""

from __future__ import annotations

from . import gauss, rational, rk, splitting, taylor
from .base import Method

__all__ = ["FAMILIES", "METHODS", "Method"]

FAMILIES = (rk, gauss, taylor, splitting, rational)

METHODS: dict[str, Method] = {m.name: m for fam in FAMILIES for m in fam.INTEGRATORS}
