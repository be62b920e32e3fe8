"""vier6, vier7: Psi = Phi^T; Phi S = S Psi and Upsilon Phi = Psi Upsilon are antisymmetric;
Upsilon Phi^-1 = Psi^-1 Upsilon and Phi^-1 S = S Psi^-1 are antisymmetric; det Phi = det Psi.
Exactly for rational data, at high precision for irrational constants, and read off each
implementation's Poisson tensor (blocks of vier9) in every conditioning regime.

The registered checks of ``tstarg verify`` (the control negative[tensor_blocks: perturbed P], among others) run
in tests/test_identity_checks.py; this file adds the per-family and per-catalogue strata.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tstarg.properties import identities as idn
from tstarg.properties.identity_checks import (
    IMPLEMENTATIONS,
    _nonsymmetric_upsilon_models,
    model_points,
)
from tstarg.properties.profiles import ref_examples
from tstarg.properties.strategies import FAMILIES, REGIMES, cocycles, rationals, upsilons
from tstarg.refimpl import catalogue
from tstarg.refimpl.reference import DegeneratePointError


@pytest.mark.parametrize("family", FAMILIES)
def test_identities_exact_per_family(family):
    """vier6/vier7 hold exactly (sympy rationals) for random models of each algebra family."""

    @settings(max_examples=ref_examples(0.6))
    @given(model_points(max_dim=4, families=[family], rational=True))
    def inner(ex):
        model, _, pi = ex
        try:
            m = idn.phi_psi_identities(
                model["algebra"], model["theta"], model["upsilon"], pi, exact=True
            )
        except ValueError:  # Delta = 0 exactly: the inverse identities do not apply
            assume(False)
        assert m.error == 0, f"{model['algebra'].name}: {m.where}"

    inner()


@pytest.mark.parametrize("name", ["Bianchi VI_h(h=-2)", "Bianchi VII_h(h=3)", "su(3)"])
@settings(max_examples=ref_examples(0.1))
@given(data=st.data())
def test_identities_high_precision_irrational(name, data):
    """vier6/vier7 at 30 digits for algebras with irrational constants (sqrt 2, sqrt 3);
    tolerance n 10^-27 cond(Phi) scale^n."""
    alg = catalogue(name)
    theta = data.draw(cocycles(alg))
    ups = data.draw(upsilons(alg.dim, zero=False))
    pi = data.draw(st.lists(rationals(denominator=4), min_size=alg.dim, max_size=alg.dim))
    m = idn.phi_psi_identities(alg, theta, ups, pi, exact=False, dps=30)
    assert m.ratio <= 1, f"{name}: {m}"


CASES = [("fast", r) for r in REGIMES] + [("reference", "generic"), ("reference", "large_momenta")]


@pytest.mark.parametrize("impl, regime", CASES)
def test_tensor_blocks(impl, regime):
    """The implementation's tensor, taken to the body frame, has the vier9 blocks: B_xx, B_pp
    antisymmetric, B_px = -B_xp^T, Psi B_xp = 1, Phi B_px = -1, B_xx Phi = -U, B_pp Psi = -S;
    tolerance 8n(|Phi| 2n|A|^2 e + n eps |Phi||B|), e the tensor's entry error bound."""
    get = IMPLEMENTATIONS[impl]

    @settings(max_examples=ref_examples(0.6 if impl == "fast" else 0.2))
    @given(model_points(max_dim=4, exact_point=False, regime=regime))
    def inner(ex):
        model, x, pi = ex
        alg = model["algebra"]
        try:
            P, bound = get(alg.f, model["theta"], model["upsilon"], x, pi)
        except DegeneratePointError:
            assume(False)
        m = idn.tensor_blocks(P, bound, alg, model["theta"], model["upsilon"], x, pi)
        assert m.ratio <= 1, f"{impl}/{regime} {alg.name}: {m}"

    inner()


@settings(max_examples=ref_examples(0.4))
@given(_nonsymmetric_upsilon_models())
def test_negative_control_upsilon_not_antisymmetric(ex):
    """Negative control: with a non-antisymmetric Upsilon and S != 0 some identity of vier6/vier7 fails."""
    model, _, pi = ex
    alg = model["algebra"]
    S = np.einsum("m,mab->ab", np.array(pi, dtype=float), alg.f) - np.array(
        model["theta"], dtype=float
    )
    assume(S.any())
    try:
        m = idn.phi_psi_identities(alg, model["theta"], model["upsilon"], pi, exact=True)
    except ValueError:
        assume(False)
    assert m.error > 0


def test_identities_exact_with_irrational_constants():
    """VII_h(h=3) has ``sqrt(3)`` in its structure constants, so ``Phi^-1`` has unsimplified
    algebraic entries: the exact route must decide zero exactly (it raised sympy's "cannot
    determine truth value" on CI seed 851072590). An antisymmetric Upsilon gives 0 (vier6,
    vier7 hold); the same model with a non-antisymmetric Upsilon (the CI's falsifying example)
    must give a positive error on ``Upsilon Phi^-1`` or another vier6/vier7 residual."""
    alg = catalogue("Bianchi VII_h(h=3)")
    theta = np.array([[0, Fraction(-3, 4), Fraction(-1, 4)], [Fraction(3, 4), 0, 0],
                      [Fraction(1, 4), 0, 0]], dtype=object)  # fmt: skip
    pi = [0, 0, Fraction(-3, 5)]
    anti = np.array([[0, Fraction(1, 2), Fraction(-1, 2)], [Fraction(-1, 2), 0, Fraction(1, 8)],
                     [Fraction(1, 2), Fraction(-1, 8), 0]], dtype=object)  # fmt: skip
    good = idn.phi_psi_identities(alg, theta, anti, pi, exact=True)
    assert good.error == 0, good
    bad_upsilon = anti.copy()
    bad_upsilon[1, 0] = 0  # Upsilon_10 != -Upsilon_01
    bad = idn.phi_psi_identities(alg, theta, bad_upsilon, pi, exact=True)
    assert bad.error > 0 and bad.ratio == float("inf"), bad
