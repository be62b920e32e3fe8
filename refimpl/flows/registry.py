"""The registry of the fast flow methods: every ``INTEGRATORS`` entry of the modules in
:mod:`refimpl.flows.integrators`, by name, in ``rank`` order; and the default choice per model."""

from __future__ import annotations

import importlib
import pkgutil

from .. import _compiled_taylor as _ct
from .. import _full_state, _full_state_rational
from .._flow_compiled import supports_full
from ..model import Model
from . import integrators as _integrators
from .base import Integrator

__all__ = ["METHODS", "choose", "method"]


def _discover(package=_integrators) -> dict[str, Integrator]:
    """The ``INTEGRATORS`` of every public module of ``package``, by name, in ``rank`` order."""
    found: list[Integrator] = []
    for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"{package.__name__}.{info.name}")
        for meth in getattr(mod, "INTEGRATORS", ()):
            if not isinstance(meth, Integrator):
                raise TypeError(f"{mod.__name__}.INTEGRATORS holds {meth!r}, not an Integrator")
            found.append(meth)
    out: dict[str, Integrator] = {}
    for meth in sorted(found, key=lambda m: m.rank):
        if meth.name in out:
            raise ValueError(f"two integrators named {meth.name!r}")
        out[meth.name] = meth
    return out


METHODS: dict[str, Integrator] = _discover()
"""Every fast flow method by name (the order: each integrator's ``rank``)."""


def method(name: str) -> Integrator:
    """The method called ``name`` (``ValueError`` listing the known ones otherwise)."""
    if name not in METHODS:
        raise ValueError(f"unknown flow method {name!r}; known: {sorted(METHODS)}")
    return METHODS[name]


def choose(model: Model, *, full: bool = False) -> Integrator:
    """The fastest method meeting a tolerance: the compiled adaptive Taylor method on the su(2) full
    state (``full``) when numba is present (``taylor``, or ``taylor-rational`` when ``Upsilon != 0``),
    ``taylor`` on the full state of every other algebra with ``Upsilon = 0`` (:mod:`refimpl._full_state`)
    and ``taylor-rational`` with ``Upsilon != 0`` (:mod:`refimpl._full_state_rational`), else DOP853
    (``Upsilon = 0``) or Gauss6 (``Upsilon != 0``)."""
    if full and _ct.HAVE_NUMBA and supports_full(model):
        return METHODS["taylor"] if model.upsilon_zero else METHODS["taylor-rational"]
    if full and _full_state.applies(model):  # every other algebra with Upsilon = 0 (G = rho(g))
        return METHODS["taylor"]
    if full and _full_state_rational.applies(model):  # Upsilon != 0 off su(2) (G = rho(g))
        return METHODS["taylor-rational"]
    return METHODS["dop853"] if model.upsilon_zero else METHODS["gauss6"]
