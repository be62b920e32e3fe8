"""At a point of the degenerate set Pi_1 (exactly representable) the implementation raises
``ValueError`` or returns non-finite values; finite numbers there fail."""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from hypothesis import strategies as st

from tstarg.refimpl import su2

from .._common import (
    _call,
)
from ..check import Check


def _poisson_degenerate(impl, dom, stats):
    """su(2), Upsilon = tau.eps with tau = (0, 0, 1/2): the plane pi'_3 = 2 is Pi_1 (exact in binary)."""

    def body(ex):
        p1, p2, x = ex
        f = su2().f
        ups = np.einsum("l,lmn->mn", np.array([0.0, 0.0, 0.5]), f)
        pi = np.array([p1, p2, 2.0])
        try:
            out = np.asarray(
                _call(impl, "poisson_tensor", f, np.zeros((3, 3)), ups, np.array(x), pi),
                dtype=float,
            )
        except ValueError:
            return 0.0, None
        if np.all(np.isfinite(out)):
            raise AssertionError(
                f"finite Poisson tensor returned on the degenerate set (pi = {pi.tolist()}): "
                "must raise ValueError or return non-finite values"
            )
        return 0.0, None

    small = st.floats(-2, 2, allow_nan=False)
    return body, st.builds(
        DegenerateExample, small, small, st.lists(st.floats(-1, 1), min_size=3, max_size=3)
    )


DegenerateExample = namedtuple("DegenerateExample", "pi_1 pi_2 x")
"""su(2) with ``tau = (0, 0, 1/2)``: ``pi = (pi_1, pi_2, 2)`` lies on Pi_1."""


def _applies(impl, dom):
    if not dom.upsilon or not dom.admits(su2().f):
        return "the declared domain has no su(2) model with Upsilon != 0 (where this check's degenerate set lies)"
    return None


CHECK = Check(
    id="poisson_tensor.degenerate",
    needs=("poisson_tensor",),
    equations="vier7, vier12",
    build=_poisson_degenerate,
    order=30,
    budget=lambda k: max(3, k // 4),
    applies=_applies,
)
