"""Both implementations satisfy the implementation protocol of docs/design.md: shapes, batch axes,
exact inputs, fixed import names, and agreement with each other through the protocol."""

from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest

from tstarg import refimpl
from tstarg.refimpl import Implementation, catalogue, su2


def test_fixed_import_names():
    assert refimpl.fast.implementation.batched is True
    assert refimpl.reference.implementation.dps == 50
    for impl in (refimpl.fast.implementation, refimpl.reference.implementation):
        assert isinstance(impl, Implementation) and impl.name and impl.version


@pytest.mark.parametrize("shape", [(), (4,), (2, 3)])
def test_fast_batch_axes(shape):
    alg = catalogue("se(2)")
    rng = np.random.default_rng(3)
    x = rng.uniform(-0.5, 0.5, shape + (3,))
    pi = rng.normal(size=shape + (3,))
    ups = np.array([[0, 0.2, 0], [-0.2, 0, 0.1], [0, -0.1, 0]])
    P = refimpl.fast.implementation.poisson_tensor(alg.f, np.zeros((3, 3)), ups, x, pi)
    assert P.shape == shape + (6, 6) and P.dtype == np.float64
    xd, pd = refimpl.fast.implementation.hamiltonian_vector_field(
        alg.f, np.zeros((3, 3)), ups, np.eye(3), None, x, pi
    )
    assert xd.shape == shape + (3,) and pd.shape == shape + (3,)
    # batch entries equal the unbatched evaluation of the same point
    if shape:
        idx = (0,) * len(shape)
        P0 = refimpl.fast.implementation.poisson_tensor(
            alg.f, np.zeros((3, 3)), ups, x[idx], pi[idx]
        )
        assert np.array_equal(P0, P[idx])


def test_reference_exact_inputs_give_mpmath_objects():
    ref = refimpl.reference.implementation
    f = su2().f_exact
    third = Fraction(1, 3)
    P = ref.poisson_tensor(
        f,
        [[0, 0, 0]] * 3,
        [[0, third, 0], [-third, 0, 0], [0, 0, 0]],
        ["0.1", "0.2", "0.3"],
        [1, 2, "1/7"],
    )
    assert P.dtype == object and isinstance(P[0, 3], mpmath.mpf)
    Pf = ref.poisson_tensor(su2().f, np.zeros((3, 3)), np.zeros((3, 3)), np.zeros(3), np.ones(3))
    assert Pf.dtype == np.float64


def test_float_reference_and_fast_agree_through_protocol():
    alg = catalogue("Bianchi VII_h(h=3)")
    x, pi = np.array([0.2, -0.3, 0.4]), np.array([0.9, 0.1, -1.2])
    ups = np.array([[0, 0.3, 0.1], [-0.3, 0, 0.0], [-0.1, 0, 0]])
    theta = np.zeros((3, 3))
    Pr = refimpl.reference.implementation.poisson_tensor(alg.f, theta, ups, x, pi)
    res = refimpl.fast.implementation.poisson_batch(alg.f, theta, ups, x, pi)
    assert np.max(np.abs(Pr - res.P)) <= res.error_bound
