"""oracles: independent judges -- published tables, closed forms, symbolic checks.

Public API: :data:`PUBLISHED_H2` (second Betti numbers of the catalogue, with sources).
"""

from .published import PUBLISHED_H2

__all__ = ["PUBLISHED_H2"]
