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
