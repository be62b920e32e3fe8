"""Issue 30, the fast implementation at its boundary: every reproducer of the issue is a test.

The boundary is stated once, in :mod:`refimpl._validate` (magnitudes, dimension, memory, time,
``out=`` buffers); these tests hold the fast path to it. Hangs are tested with budgets that refuse
at once (the time budget is patched down, or the estimate alone crosses it), never by waiting.
"""

from __future__ import annotations

import numpy as np
import pytest

from tstarg.refimpl import _validate, fast, su2
from tstarg.refimpl._validate import (
    MAX_DIMENSION,
    MAX_MAGNITUDE,
    BudgetError,
    StepBudget,
    TimeBudget,
    check_batch_memory,
)
from tstarg.refimpl.flows import fast_flow

F = su2().f
Z3 = np.zeros((3, 3))
I3 = np.eye(3)
X3 = np.array([0.1, 0.2, 0.3])
P3 = np.array([0.3, 0.2, -0.4])
FAST = fast.implementation


# ------------------------------------------------------------------ magnitudes
@pytest.mark.parametrize("big", [1.7e308, 1e301, np.nextafter(MAX_MAGNITUDE, np.inf)])
@pytest.mark.parametrize("compiled", [True, False])
def test_momenta_beyond_the_magnitude_boundary_are_refused(big, compiled):
    """``pi = 1.7e308`` was accepted where the reference refuses magnitudes over 1e300."""
    with pytest.raises(ValueError, match=r"pi has an entry of magnitude .* beyond the boundary"):
        FAST.poisson_batch(F, Z3, Z3, X3, np.array([1.0, 2.0, big]), compiled=compiled)
    with pytest.raises(ValueError, match="beyond the boundary"):
        FAST.hamiltonian_vector_field(F, Z3, Z3, I3, None, X3, np.array([1.0, 2.0, big]))


@pytest.mark.parametrize("name", ["theta", "upsilon", "f"])
def test_model_entries_beyond_the_boundary_are_refused(name):
    big = 1e305
    args = {"f": F, "theta": Z3, "upsilon": Z3}
    args[name] = {"f": F * big, "theta": np.array([[0, big, 0], [-big, 0, 0], [0, 0, 0]])}.get(
        name, np.array([[0, big, 0], [-big, 0, 0], [0, 0, 0]])
    )
    with pytest.raises(ValueError, match="beyond the boundary"):
        FAST.poisson_tensor(args["f"], args["theta"], args["upsilon"], X3, P3)


def test_a_vector_field_that_overflows_is_refused_not_returned_as_inf():
    """``F.hamiltonian_vector_field(su2, Z3, Z3, I3, None, x3, p3 * 1e300)`` returned non-finite
    numbers with no error. ``pidot = pi x I^-1 pi`` squares 1e300: the result is not representable
    (the exact value is 0 for I = 1, but float64 cannot form it); refused as overflow."""
    with pytest.raises(ValueError, match="pidot overflows float64"):
        FAST.hamiltonian_vector_field(F, Z3, Z3, I3, None, X3, P3 * 1e300)


def test_overflow_with_upsilon_zero_is_never_called_degenerate():
    """With Upsilon = 0, Phi = 1: no point is degenerate. A point the kernels flag because its
    diagnostics overflowed is refused as overflow (the probe saw 'degenerate' there)."""
    P = np.full((2, 6, 6), np.nan)
    with pytest.raises(ValueError, match="P overflows float64 at batch indices") as info:
        _validate.refuse_overflow("poisson_tensor", {"P": P}, np.array([True, False]), True)
    assert "degenerate" not in str(info.value)
    # with Upsilon != 0 the flagged point is left to the degenerate error; the other one is not
    with pytest.raises(ValueError, match=r"batch indices \[\(1,\)\]"):
        _validate.refuse_overflow("poisson_tensor", {"P": P}, np.array([True, False]), False)
    # a correct result near the boundary passes: P_pp = [pi]_x / C1 with C1 = 1 holds 4e299
    P = FAST.poisson_tensor(F, Z3, Z3, X3, P3 * 1e300)
    assert P[3, 4] == pytest.approx(-P3[2] * 1e300, rel=1e-15)


def test_structure_constants_scaled_by_1e200_get_a_clear_error_not_overflowerror():
    """``f`` scaled by 1e200 raised ``OverflowError`` from the Jacobi tolerance ``scale**2``."""
    with pytest.raises(ValueError) as info:
        FAST.poisson_tensor(F * 1e200, Z3, Z3, X3, P3)
    assert not isinstance(info.value, OverflowError)
    # the Jacobi check itself now runs scaled: f * 1e200 is a Lie algebra (Jacobi is homogeneous)
    assert _validate.check_structure_constants(F * 1e200).shape == (3, 3, 3)
    rng = np.random.default_rng(1)
    bad = rng.standard_normal((3, 3, 3))
    bad = 1e200 * (bad - bad.transpose(0, 2, 1))  # antisymmetric, Jacobi broken at O(1) relative
    with pytest.raises(ValueError, match="Jacobi identity"):
        _validate.check_structure_constants(bad)


# ------------------------------------------------------------------ dimension and memory
@pytest.mark.parametrize("n", [150, 300])
def test_large_dimension_is_refused_at_once_with_the_estimate(n):
    """An abelian algebra of dimension 150 hung (> 30 s); at 300 einsum asked for 60.3 GiB."""
    f = np.zeros((n, n, n))
    with pytest.raises(BudgetError, match=rf"dimension n = {n} exceeds the dimension budget") as e:
        FAST.poisson_tensor(f, np.zeros((n, n)), np.zeros((n, n)), np.zeros(n), np.zeros(n))
    assert "GiB" in str(e.value)
    from tstarg.refimpl import abelian

    with pytest.raises(BudgetError, match="dimension budget"):
        abelian(n)


def test_the_largest_accepted_dimension_still_works():
    """At ``MAX_DIMENSION`` the abelian algebra's Poisson tensor is the canonical one: with
    ``f = 0``, ``Theta = Upsilon = 0`` it is ``[[0, 1], [-1, 0]]`` (vier9 with S = 0, Phi = 1)."""
    n = MAX_DIMENSION
    P = FAST.poisson_tensor(
        np.zeros((n, n, n)), np.zeros((n, n)), np.zeros((n, n)), np.zeros(n), np.ones(n)
    )
    want = np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]])
    assert np.array_equal(P, want)


def test_a_batch_beyond_the_memory_budget_is_refused_before_allocation():
    with pytest.raises(BudgetError, match="GiB of working memory"):
        check_batch_memory(10**9, 3, what="poisson_batch")
    # the batch check runs before the inputs are touched: a broadcast view costs nothing
    x = np.broadcast_to(X3, (10**8, 3))
    with pytest.raises(BudgetError, match="poisson_batch: 100000000 points"):
        FAST.poisson_batch(F, Z3, Z3, x, x)


# ------------------------------------------------------------------ out= and aliasing
def test_a_read_only_out_is_refused_by_name():
    """``out=<read-only array>`` raised numba's 'No matching definition'."""
    x, p = np.zeros((4, 3)), np.ones((4, 3))
    out = np.zeros((4, 6, 6))
    out.flags.writeable = False
    for compiled in (True, False):
        with pytest.raises(ValueError, match="out is a read-only array"):
            FAST.poisson_batch(F, Z3, Z3, x, p, out=out, compiled=compiled)


@pytest.mark.parametrize("target", ["x", "pi"])
def test_an_out_that_aliases_an_input_is_refused_and_the_input_survives(target):
    """An ``out=`` aliasing ``x`` overwrote the caller's input."""
    buf = np.zeros(4 * 36)
    x, p = np.full((4, 3), 0.1), np.ones((4, 3))
    view = buf[:12].reshape(4, 3)
    if target == "x":
        view[:] = x
        x = view
    else:
        view[:] = p
        p = view
    before = buf.copy()
    with pytest.raises(ValueError, match=f"out overlaps the input {target}"):
        FAST.poisson_batch(F, Z3, Z3, x, p, out=buf.reshape(4, 6, 6))
    assert np.array_equal(buf, before)


def test_a_separate_out_is_written_and_returned():
    x, p = np.full((4, 3), 0.1), np.ones((4, 3))
    out = np.empty((4, 6, 6))
    res = FAST.poisson_batch(F, Z3, Z3, x, p, out=out)
    assert res.P is out and np.array_equal(out, FAST.poisson_batch(F, Z3, Z3, x, p).P)


# ------------------------------------------------------------------ time budgets
def test_time_budget_refuses_before_the_work_with_the_estimate():
    b = TimeBudget("unit", seconds=1.0)
    with pytest.raises(BudgetError, match=r"would take about 5 s of CPU .* budget of 1 s"):
        b.refuse_if(5.0, "a piece of work")
    b.refuse_if(0.0, "nothing")


def test_a_steps_count_inside_its_budget_is_still_refused_in_time():
    """``fast_flow(su2, ..., t = 1e4, steps = 10**7)`` ran past a minute inside the steps budget:
    the cost of 10**7 steps is estimated from a 16-step probe and refused before the run."""
    with pytest.raises(BudgetError, match=r"10000000 steps .* over the time budget"):
        fast_flow(F, Z3, Z3, I3, None, X3, P3, 1e4, steps=10**7)


def test_step_doubling_is_refused_before_its_first_two_runs(monkeypatch):
    """``F.flow(so4, ..., Upsilon != 0, t = 1e4)`` and ``F.flow(se3, gravity, t = 1e3)`` ran past a
    minute with no message. With the budget patched down to nothing the same calls are refused at
    once, with the estimate, before any full run: the protocol's default (the compiled rational
    Taylor flow since issue 25) by the adaptive probe, and Gauss6 under step doubling (the route
    without numba, asked by name here) before its first two runs."""
    from tstarg.refimpl import se3, so4

    monkeypatch.setattr(_validate, "TIME_BUDGET_S", 1e-9)
    n = 6
    rng = np.random.default_rng(0)
    A = 0.1 * rng.standard_normal((n, n))
    args = (so4().f, np.zeros((n, n)), A - A.T, np.eye(n), None, np.full(n, 0.1), np.full(n, 0.2))
    with pytest.raises(BudgetError, match=r"would take about .* over the time budget"):
        FAST.flow(*args, 1e4)
    with pytest.raises(BudgetError, match="step doubling's first two runs"):
        fast_flow(*args, 1e4, method_name="gauss6")
    pot = {"kind": "gravity", "L": np.eye(n)[5], "gamma": np.eye(n)[5]}
    with pytest.raises(BudgetError, match="over the time budget"):
        FAST.flow(
            se3().f,
            np.zeros((n, n)),
            np.zeros((n, n)),
            np.eye(n),
            pot,
            np.full(n, 0.1),
            np.full(n, 0.2),
            1e3,
        )


def test_step_budget_measures_its_probe():
    b = StepBudget("unit", seconds=10.0)
    b.calibrate(lambda k: sum(range(20000 * k)), 4)
    assert b.per_step > 0
    with pytest.raises(BudgetError, match="steps at"):
        b.before(int(20 / b.per_step) + 1, "a long run")
