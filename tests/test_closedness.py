"""d omega_L = 0 (vier2, vier3): the cyclic sum d_i Omega_jk + d_j Omega_ki + d_k Omega_ij of the
holonomic matrix of omega_L vanishes -- exactly (sympy) and at high precision (mpmath.diff);
it fails when f breaks Jacobi or Theta is not a cocycle (zeven1).

The registered checks of ``tstarg verify`` (closedness[mp] and the control negative[closedness: f breaks Jacobi], among others) run
in tests/test_identity_checks.py; this file adds the per-family and per-catalogue strata.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings

from tstarg.properties import identities as idn
from tstarg.properties.identity_checks import (
    _non_cocycle_models,
)
from tstarg.properties.profiles import ref_examples
from tstarg.properties.strategies import FAMILIES, lie_algebras, models
from tstarg.refimpl import CATALOGUE_NAMES, catalogue


@pytest.mark.parametrize("family", FAMILIES)
def test_closed_exact_per_family(family):
    """d omega_L = 0 exactly, pi symbolic, for random algebras of each family with random Theta, Upsilon."""

    @settings(max_examples=ref_examples(0.4))
    @given(models(algebras=lie_algebras(max_dim=5, families=[family])))
    def inner(model):
        m = idn.closedness_exact(model["algebra"], model["theta"], model["upsilon"])
        assert m.error == 0, f"d omega_L != 0 for {model['algebra'].name}: {m.where}"

    inner()


@pytest.mark.parametrize("name", [n for n in CATALOGUE_NAMES if catalogue(n).dim <= 6])
def test_closed_exact_catalogue(name):
    """d omega_L = 0 exactly for each catalogue algebra (irrational constants included) with a fixed
    non-zero Upsilon and the sum of its cocycle basis as Theta."""
    from tstarg.refimpl import cocycle_basis

    alg = catalogue(name)
    n = alg.dim
    theta = sum(cocycle_basis(alg), np.zeros((n, n), dtype=object))
    ups = np.full((n, n), Fraction(0), dtype=object)
    for i in range(n):
        for j in range(i + 1, n):
            ups[i, j] = Fraction(i + 2 * j, 7)
            ups[j, i] = -ups[i, j]
    m = idn.closedness_exact(alg, theta, ups)
    assert m.error == 0, f"d omega_L != 0 for {name}: {m.where}"


@settings(max_examples=ref_examples(0.2))
@given(_non_cocycle_models())
def test_negative_control_theta_not_cocycle(ex):
    """Negative control: a Theta with delta_2 Theta != 0 gives d omega_L != 0, exactly and at high precision."""
    model, x, pi = ex
    assert idn.closedness_exact(model["algebra"], model["theta"], model["upsilon"]).error > 0
    m = idn.closedness_mp(model["algebra"], model["theta"], model["upsilon"], x, pi, dps=25)
    assert m.ratio > 1e6, f"the high-precision route missed a non-cocycle: {m}"
