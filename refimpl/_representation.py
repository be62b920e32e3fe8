"""Faithful matrix representations used to re-express ``g = exp(x)`` when a flow leaves the chart."""

from __future__ import annotations

import numpy as np

from ._catalogue import CATALOGUE_NAMES, catalogue

__all__ = ["catalogue_match"]


def catalogue_match(f):
    """The catalogue algebra with exactly these structure constants (for its representation), or None."""
    for name in CATALOGUE_NAMES:
        alg = catalogue(name)
        if alg.f.shape == f.shape and np.array_equal(alg.f, f) and alg.rep is not None:
            return alg
    return None
