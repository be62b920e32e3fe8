"""properties: Hypothesis strategies and the paper's identities as property checks.

Public API:

* :mod:`properties.strategies` -- ``lie_algebras`` (catalogue, class A/B Bianchi, basis
  changes, solvable, nilpotent, semidirect, direct sums), ``basis_changes``, ``cocycles``
  (``coboundary=``), ``upsilons``, ``points`` (``REGIMES``), ``models``, ``scenes``,
  ``catalogue_algebras``, ``rationals``, ``phi_condition``, ``degeneracy_condition``, and the
  negative controls
  ``jacobi_breaking_constants``, ``non_cocycles``;
* :mod:`properties.identities` -- the identities as plain functions returning a
  :class:`~properties.identities.Measurement` (closedness, vier6/vier7, Jacobi, Darboux,
  Whitehead);
* :mod:`properties.core_checks` -- ``CheckResult``, ``run_property``, ``core_checks``;
* :mod:`properties.identity_checks` -- ``identity_checks``, the ``tstarg verify`` provider of the
  identities and their negative controls.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .identities import Measurement
    from .strategies import (
        FAMILIES,
        REGIMES,
        basis_changes,
        catalogue_algebras,
        cocycles,
        degeneracy_condition,
        is_nilpotent,
        is_solvable,
        jacobi_breaking_constants,
        lie_algebras,
        models,
        non_cocycles,
        phi_condition,
        points,
        rationals,
        scenes,
        upsilons,
    )

_WHERE = {"Measurement": "identities"}
"""The public names and the submodule defining each: imported on first use (PEP 562), so that
``tstarg --help`` and the profile table (:mod:`properties.profiles`) do not load the strategies,
numpy and the kernels."""

__all__ = [
    "FAMILIES",
    "REGIMES",
    "Measurement",
    "basis_changes",
    "catalogue_algebras",
    "cocycles",
    "degeneracy_condition",
    "is_nilpotent",
    "is_solvable",
    "jacobi_breaking_constants",
    "lie_algebras",
    "models",
    "non_cocycles",
    "phi_condition",
    "points",
    "rationals",
    "scenes",
    "upsilons",
]


def __getattr__(name: str):
    module = _WHERE.get(name, "strategies" if name in __all__ else None)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value
