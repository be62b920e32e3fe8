"""Issue 30, the mpmath reference at the boundary of :mod:`refimpl._validate` (shared with the fast
and rigorous implementations): every reproducer is a test, each refused at once by name."""

from __future__ import annotations

import numpy as np
import pytest

from tstarg.refimpl import fast, sl2r, su2
from tstarg.refimpl._errors import DegeneratePointError
from tstarg.refimpl._validate import MAX_DPS, BudgetError
from tstarg.refimpl.reference import Reference

F = su2().f
Z3 = np.zeros((3, 3))
X3 = np.array([0.1, 0.2, 0.3])
P3 = np.array([0.3, 0.2, -0.4])
TAU = np.array([0.25, -0.5, 0.5])
REF = Reference(20)


def test_a_numerically_singular_frame_is_a_clear_refusal_not_zerodivisionerror():
    """``R.poisson_tensor(sl2r, Z3, Z3, 150 * dir, p3)`` raised ZeroDivisionError inside mpmath:
    along ``h`` the eigenvalues of ``ad_x`` are ``+-300`` (real), so ``phi1(-ad_x)`` spans
    ``e^300`` and mpmath's LU meets a pivot below ``||.|| eps``."""
    with pytest.raises(ValueError, match="numerically singular at 20 digits") as info:
        REF.poisson_tensor(sl2r(), Z3, Z3, 150 * np.array([1.0, 0.0, 0.0]), P3)
    assert not isinstance(info.value, ZeroDivisionError)


@pytest.mark.parametrize("big", [1.7e308, 1e301])
def test_magnitudes_beyond_the_boundary_are_refused_like_the_fast_path(big):
    pi = np.array([1.0, 2.0, big])
    for impl in (REF, fast.implementation):
        with pytest.raises(ValueError, match="magnitude"):
            impl.poisson_tensor(F, Z3, Z3, X3, pi)


def test_a_float_result_that_overflows_is_refused_by_both_implementations():
    """``pidot = pi x I^-1 pi`` at ``|pi| ~ 1e300`` and ``I = diag(1, 2, 3)`` is ~1e600: the reference
    computes it in mpmath but cannot return it as float64; the fast path cannot form it. Both refuse
    (before this, the reference returned inf)."""
    I = np.diag([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="overflows float64"):
        REF.hamiltonian_vector_field(F, Z3, Z3, I, None, X3, P3 * 1e300)
    with pytest.raises(ValueError, match="overflows float64"):
        fast.implementation.hamiltonian_vector_field(F, Z3, Z3, I, None, X3, P3 * 1e300)


def test_the_precision_cap_is_the_boundary_s():
    with pytest.raises(BudgetError, match=f"precision cap.*{10**9}"):
        Reference(10**9)
    assert Reference(MAX_DPS).dps == MAX_DPS


def _hat(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


@pytest.mark.parametrize("s", [1e10, 1e33, 2.6e49])
def test_far_from_singular_phi_is_decided_relative_to_its_scale_and_answered(s):
    """su(2) with ``tau``, ``pi`` scaled by ``s``: ``Phi = C1 1 + tau pi'^T`` has ``Delta = C1^2``
    (``C1 = 1 - pi'.tau = 1 + 0.225 s^2``; ~2.4e198 at s = 2.6e49), never 0, yet below
    ``16 n eps ||Phi||^n`` at 20 digits: the reference refused it as 'Delta = det Phi = 0' (the
    probe's well-conditioned points). It now decides Delta at more digits and inverts Phi there.
    Independent route: the closed form of section cinq, ``P_pp = [pi']_x / C1`` (Theta = 0)."""
    U = np.einsum("l,lmn->mn", TAU * s, F)
    pi = P3 * s
    P = REF.poisson_tensor(F, Z3, U, X3, pi)
    c1 = 1 + 0.225 * s * s  # pi.tau = s^2 (0.075 - 0.1 - 0.2), exact to float rounding
    want = _hat(pi) / c1
    # error model: want carries the rounding of c1 and of the products (a few eps relative)
    assert np.all(np.abs(P[3:, 3:] - want) <= 8 * np.finfo(float).eps * np.abs(want).max())


def test_an_exactly_degenerate_point_is_still_refused_after_escalation():
    """``pi.tau = 1`` exactly in binary (``pi = 4 e_1``, ``tau_1 = 1/4``): ``C1 = 0``, Delta = 0 at
    every precision: refused at the precision cap, relative to Phi."""
    U = np.einsum("l,lmn->mn", TAU, F)
    with pytest.raises(
        DegeneratePointError, match="zero to working precision relative to the scale"
    ):
        REF.poisson_tensor(F, Z3, U, X3, np.array([4.0, 0.0, 0.0]))


def test_a_long_reference_flow_is_refused_early_with_its_extrapolated_cost(monkeypatch):
    """``REF.flow(..., t = 1e3)`` costs about a CPU second per unit time: the run is refused as
    soon as the cost extrapolated from its progress crosses the budget (patched down here so that
    the first steps decide), with the estimate, instead of running for minutes."""
    from tstarg.refimpl import _validate

    monkeypatch.setattr(_validate, "TIME_BUDGET_S", 1e-3)
    monkeypatch.setattr(_validate.ProgressBudget, "grace", 0.0)
    with pytest.raises(
        BudgetError, match=r"reference flow: the flow to t = 1000.0 would take about"
    ):
        REF.flow(F, Z3, Z3, np.diag([1.0, 2.0, 3.0]), None, X3, P3, 1e3)


def test_progress_budget_extrapolates_from_the_fraction_done():
    from tstarg.refimpl._validate import ProgressBudget

    b = ProgressBudget("unit", seconds=10.0)
    b.grace = 0.0
    b.start -= 2.0  # two CPU seconds already spent
    b.progress(0.5, "half way")  # 4 s in total: within the budget
    with pytest.raises(
        BudgetError, match=r"about 20 s of CPU \(extrapolated after 10% of the span"
    ):
        b.progress(0.1, "a tenth")
