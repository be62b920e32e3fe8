"""Taylor-series flow methods (refimpl._taylor): the quadratic field, the two kernels, bad input.

The fitted orders are in tests/test_flow_orders.py; here: the polynomial form of the body field equals
the generic formulas (vier10/vier11 with Phi = 1, twee17 corrected), the batched numpy kernel performs the
same arithmetic as the generated scalar code (chunks, constant components, observers), and bad input is
refused with a clear ValueError.
"""

from __future__ import annotations

import numpy as np
import pytest

from tstarg.refimpl import catalogue, su2
from tstarg.refimpl._taylor import (
    numpy_taylor_integrator,
    quadratic_field,
    scalar_taylor_integrator,
)
from tstarg.refimpl.flows import METHODS, NumpyModel, integrate_fast

EPS = np.finfo(float).eps
SU2 = su2()
Z = np.zeros((3, 3))
XI = np.array([0.2, -0.1, 0.3])
THETA = -np.einsum("k,kab->ab", XI, SU2.f)
GRAV = {"kind": "gravity", "L": np.array([0.1, -0.2, 1.0]), "gamma": np.array([0.0, 0.0, -1.0])}
I_OFF = np.array([[1.0, 0.1, 0.0], [0.1, 1.3, -0.05], [0.0, -0.05, 0.5]])  # not principal axes
B3 = catalogue("Bianchi III")
THETA_B3 = np.array([[0.0, 0.5, 0.0], [-0.5, 0.0, 0.0], [0.0, 0.0, 0.0]])

MODELS = {
    "su2 gyrostat heavy, off-diagonal I": lambda: NumpyModel(SU2, THETA, Z, I_OFF, GRAV),
    "Lagrange top (constant pi_3)": lambda: NumpyModel(
        SU2,
        Z,
        Z,
        np.diag([1.0, 1.0, 0.5]),
        {"kind": "gravity", "L": np.array([0.0, 0.0, 1.0]), "gamma": np.array([0.0, 0.0, -1.0])},
    ),
    "su2 free gyrostat": lambda: NumpyModel(SU2, THETA, Z, np.diag([1.0, 1.3, 0.5]), None),
    "Bianchi III heavy with cocycle": lambda: NumpyModel(
        B3, THETA_B3, Z, np.diag([1.0, 1.5, 2.0]), GRAV
    ),
}


@pytest.mark.parametrize("label", list(MODELS))
def test_quadratic_field_equals_generic_field(label):
    """quadratic_field(model)(y) equals the generic einsum body field (omega_pidot, gamma_dot) on random
    states (error model: 16 eps * (|y|^2 + |y|) * coefficient scale)."""
    model = MODELS[label]()
    F = quadratic_field(model)
    n = model.n
    y = np.random.default_rng(5).normal(size=(F.d, 30))
    got = np.array(F(y))
    Omega, pidot = model.omega_pidot(y[:n], y[n:] if model.gravity else None)
    want = np.concatenate([pidot, model.gamma_dot(Omega, y[n:])]) if model.gravity else pidot
    scale = np.max(np.abs(y)) ** 2 + np.max(np.abs(y))
    coef = (
        1
        + np.max(np.abs(model.Iinv)) * (1 + np.max(np.abs(model.theta)))
        + (np.max(np.abs(model.Lvec)) if model.gravity else 0)
    )
    assert np.all(np.isfinite(got))
    assert np.max(np.abs(got - want)) <= 16 * EPS * scale * coef


def test_constant_components_are_those_with_zero_field():
    """The Lagrange top's pi_3 is constant (I_1 = I_2, L on the symmetry axis): its field is identically
    zero, and only there; the asymmetric top has no constant component."""
    assert quadratic_field(MODELS["Lagrange top (constant pi_3)"]()).constant_components() == {2}
    assert (
        quadratic_field(MODELS["su2 gyrostat heavy, off-diagonal I"]()).constant_components()
        == set()
    )


@pytest.mark.parametrize("label", list(MODELS))
@pytest.mark.parametrize("order", [5, 16])
def test_numpy_kernel_equals_scalar_kernel(label, order):
    """The batched kernel (chunks of 3 over 7 trajectories) equals the generated scalar code trajectory by
    trajectory, at the end and at every observed step (same arithmetic up to summation order: error model
    64 eps per step times the state scale)."""
    model = MODELS[label]()
    F = quadratic_field(model)
    rng = np.random.default_rng(order)
    y0 = rng.normal(size=(F.d, 7)) * 0.7
    h, steps = 0.05, 40
    seen_b, seen_s = [], []
    batch = numpy_taylor_integrator(model, order)(
        y0, h, steps, observe=lambda k, y: seen_b.append(y.copy()), chunk=3
    )
    run = scalar_taylor_integrator(model, order)
    single = np.empty_like(y0)
    for j in range(7):
        rec = []
        single[:, j] = run(y0[:, j].tolist(), h, steps, lambda k, y, rec=rec: rec.append(y))
        seen_s.append(np.array(rec))
    scale = 1 + np.max(np.abs(single))
    assert np.all(np.isfinite(batch))
    assert np.max(np.abs(batch - single)) <= 64 * steps * EPS * scale
    hist_b = np.stack(seen_b)  # (steps, d, 7)
    hist_s = np.stack(seen_s, axis=-1)  # (steps, d, 7)
    assert hist_b.shape == hist_s.shape == (steps, F.d, 7)
    assert np.max(np.abs(hist_b - hist_s)) <= 64 * steps * EPS * scale


def test_integrate_fast_dispatch_and_observer():
    """integrate_fast with a Taylor method: one trajectory (scalar code) and the same trajectory inside a
    batch larger than TAYLOR_SCALAR_MAX (numpy kernel) agree to rounding (64 eps per step), observers see
    every step."""
    from tstarg.refimpl.flows.integrators.taylor import TAYLOR_SCALAR_MAX

    model = MODELS["su2 gyrostat heavy, off-diagonal I"]()
    meth = METHODS["taylor16"]
    rng = np.random.default_rng(2)
    M = TAYLOR_SCALAR_MAX + 3
    x0, pi0 = rng.normal(size=(3, M)) * 0.3, rng.normal(size=(3, M))
    ks1, ks9 = [], []
    one = integrate_fast(
        model,
        meth,
        x0[:, :1],
        pi0[:, :1],
        3.0,
        30,
        system="body",
        observe=lambda k, p, G, x: ks1.append(k),
    )
    many = integrate_fast(
        model, meth, x0, pi0, 3.0, 30, system="body", observe=lambda k, p, G, x: ks9.append(k)
    )
    assert ks1 == ks9 == list(range(1, 31))
    scale = 1 + np.max(np.abs(one["pi"]))
    assert np.max(np.abs(one["pi"][:, 0] - many["pi"][:, 0])) <= 64 * 30 * EPS * scale
    assert np.max(np.abs(one["Gamma"][:, 0] - many["Gamma"][:, 0])) <= 64 * 30 * EPS * scale


def test_bad_input_is_refused():
    """Upsilon != 0, a non-integer or non-positive order, a wrongly shaped batch and a configuration
    system each raise a ValueError naming the problem."""
    ups = np.einsum("l,lmn->mn", np.array([0.05, 0.1, -0.08]), SU2.f)
    model_u = NumpyModel(SU2, THETA, ups, np.diag([1.0, 1.3, 0.5]), None)
    with pytest.raises(ValueError, match="Upsilon = 0"):
        quadratic_field(model_u)
    ok, why = METHODS["taylor20"].applies(model_u)
    assert not ok and "Upsilon = 0" in why
    model = MODELS["su2 free gyrostat"]()
    for bad in (0, -3, 2.5, True, "16"):
        with pytest.raises(ValueError, match="Taylor order"):
            scalar_taylor_integrator(model, bad)
        with pytest.raises(ValueError, match="Taylor order"):
            numpy_taylor_integrator(model, bad)
    with pytest.raises(ValueError, match=r"shape \(3, N\)"):
        numpy_taylor_integrator(model, 8)(np.zeros((4, 2)), 0.1, 3)
    with pytest.raises(ValueError, match="body systems only"):
        integrate_fast(
            model, METHODS["taylor12"], np.zeros((3, 1)), np.ones((3, 1)), 1.0, 4, system="full"
        )
