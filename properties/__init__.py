"""properties: Hypothesis strategies and the paper's identities as property checks.

Public API: :mod:`properties.strategies` (``catalogue_algebras``, ``cocycles``,
``upsilons``, ``points``, ``REGIMES``).
"""

from .strategies import REGIMES, catalogue_algebras, cocycles, phi_condition, points, rationals, upsilons

__all__ = ["REGIMES", "catalogue_algebras", "cocycles", "phi_condition", "points", "rationals", "upsilons"]
