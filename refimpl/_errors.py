"""The error classes of refimpl: one class per meaning, shared by every implementation."""

from __future__ import annotations

__all__ = ["DegeneratePointError", "ChartError"]


class DegeneratePointError(ValueError):
    """The point lies on the degenerate set Pi_1 (Delta = det Phi = 0, vier12): omega_L is not
    symplectic there and no Poisson tensor or vector field exists."""


class ChartError(ValueError):
    """The point lies outside the chart of exponential coordinates of the first kind (an
    eigenvalue of ``ad_x`` is ``2 pi i k``, ``k != 0``), where the frames of twee1 do not exist."""
