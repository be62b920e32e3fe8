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


def test_degenerate_to_working_precision_is_stated_relative_to_phi_not_as_zero():
    """su(2) with ``tau``, ``pi`` scaled by ``s = 1e33``: ``Phi = C1 1 + tau pi'^T`` has
    ``Delta = C1^2 ~ 5e130`` (never 0: ``C1 = 1 - pi'.tau = 1 + 0.225 s^2``) but
    ``cond(Phi) = C1 ~ 2e65`` exceeds 20 digits. The refusal says so, relative to the scale of
    Phi, instead of claiming ``Delta = det Phi = 0``."""
    s = 1e33
    U = np.einsum("l,lmn->mn", TAU * s, F)
    with pytest.raises(DegeneratePointError) as info:
        REF.poisson_tensor(F, Z3, U, X3, P3 * s)
    msg = str(info.value)
    assert "zero to working precision relative to the scale of Phi" in msg
    assert "Delta = det Phi = 0;" not in msg
