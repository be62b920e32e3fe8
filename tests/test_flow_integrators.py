"""The flows wing's contracts: one frozen Model validated once; integrators that own integrate and
refuse a request that does not fit them by name; a typed FlowResult; bounded caches."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tstarg.refimpl import Model, State, _compiled_taylor, catalogue
from tstarg.refimpl.flows import METHODS, FlowResult, StepDoubling, choose, method
from tstarg.refimpl.flows.base import Adaptive, FixedStep

SU2 = catalogue("su(2)")
Z = np.zeros((3, 3))
I = np.diag([1.0, 1.3, 0.6])
GRAV = {"kind": "gravity", "L": np.array([0.2, 0.1, 1.0]), "gamma": np.array([0.0, 0.0, -1.0])}
X0 = np.array([[0.1], [0.2], [0.0]])
PI0 = np.array([[0.3], [0.2], [1.5]])


def test_model_is_frozen_and_owns_copies():
    """Attributes cannot be rebound; the caller's arrays are copied (writing them later changes
    nothing in the model); derived data is computed once per model (the same object each time)."""
    inertia = I.copy()
    m = Model(SU2, Z, Z, inertia, GRAV)
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.inertia = np.eye(3)
    inertia[0, 0] = 99.0
    assert m.inertia[0, 0] == 1.0
    assert m.Iinv is m.Iinv and m.compiled_body_field is m.compiled_body_field
    np.testing.assert_array_equal(m.Iinv @ m.inertia, np.eye(3))  # diagonal: exact
    assert "Model(su(2), n=3, inertia=diag(1, 1.3, 0.6)" in repr(m)


def test_model_refuses_bad_input_by_name():
    """Validation is refimpl._validate's: a broken Jacobi identity, an indefinite inertia and an explicit
    None are refused naming the input."""
    f = np.zeros((3, 3, 3))
    f[0, 1, 2], f[0, 2, 1] = 1.0, -1.0
    f[1, 0, 1], f[1, 1, 0] = 1.0, -1.0  # not a Lie algebra
    with pytest.raises(ValueError, match="Jacobi|structure constants"):
        Model(f)
    with pytest.raises(ValueError, match="inertia"):
        Model(SU2, Z, Z, -np.eye(3), None)
    with pytest.raises(ValueError, match="[Tt]heta"):
        Model(SU2, None, Z, I, None)


def test_state_checked():
    """State.checked validates against the model's dimension and keeps t."""
    m = Model(SU2)
    s = State([0.1, 0.2, 0.3], [1.0, 0.0, 0.0], t=2.0).checked(m)
    assert s.x.dtype == np.float64 and s.t == 2.0
    with pytest.raises(ValueError):
        State([0.1, 0.2], [1.0, 0.0, 0.0]).checked(m)


def test_every_method_is_an_integrator_with_its_kind_of_request():
    """Every registered method is a FixedStep or an Adaptive integrator; each refuses the other kind
    of request (steps for an adaptive one, no steps for a fixed-step one) naming itself."""
    m = Model(SU2, Z, Z, I, GRAV)
    state = State(X0, PI0)
    for name, meth in METHODS.items():
        assert isinstance(meth, (FixedStep, Adaptive)) and meth.name == name
        if not meth.applies(m)[0]:
            with pytest.raises(ValueError, match=f"method {name} does not apply"):
                meth.integrate(m, state, 1.0, tol=1e-8, steps=4, system="body")
            continue
        if meth.adaptive:
            with pytest.raises(ValueError, match=f"method {name} is adaptive"):
                meth.integrate(m, state, 1.0, steps=8, system="body")
        else:
            with pytest.raises(ValueError, match=f"method {name} takes a step count"):
                meth.integrate(m, state, 1.0, tol=1e-8, system="body")
    with pytest.raises(ValueError, match="unknown flow method"):
        method("no-such-method")


def test_step_doubling_meets_its_tolerance_against_a_finer_run():
    """StepDoubling(dop853) at tol on the body system: its answer is within tol (+ rounding, 100 eps
    per step scale) of the same method at 8x its final step count, an independent run."""
    m = Model(SU2, Z, Z, I, GRAV)
    wrapped = StepDoubling(METHODS["dop853"])
    tol = 1e-9
    out = wrapped.integrate(m, State(X0, PI0), 3.0, tol=tol, system="full")
    assert isinstance(out, FlowResult) and out["pi"] is out.pi
    fine = METHODS["dop853"].integrate(m, State(X0, PI0), 3.0, steps=4096, system="full")
    eps = np.finfo(float).eps
    assert np.max(np.abs(out.pi - fine.pi)) <= tol + 100 * 4096 * eps * np.max(np.abs(fine.pi))


def test_default_choice():
    """The protocol's choice: the compiled Taylor methods on the full state (su(2): quaternion,
    ``taylor-rational`` with Upsilon; every other algebra: G = rho(g), ``taylor`` with Upsilon = 0 and
    ``taylor-rational`` otherwise), else DOP853 (the body system) or Gauss6 (Upsilon != 0, the body
    system or no numba)."""
    ups = np.einsum("l,lmn->mn", np.array([0.05, 0.02, -0.03]), SU2.f)
    b3 = catalogue("Bianchi III")
    z3 = np.zeros((3, 3))
    assert choose(Model(b3, z3, z3, I, None), full=True).name == "taylor"
    assert choose(Model(b3, z3, z3, I, None), full=False).name == "dop853"
    full_ups = "taylor-rational" if _compiled_taylor.HAVE_NUMBA else "gauss6"
    assert choose(Model(b3, z3, ups, I, None), full=True).name == full_ups
    assert choose(Model(b3, z3, ups, I, None), full=False).name == "gauss6"
    assert choose(Model(SU2, Z, Z, I, None), full=False).name == "dop853"


def test_lru_is_bounded():
    """The bounded map behind the flows' caches keeps at most maxsize entries, dropping the least
    recently used one (a read refreshes an entry)."""
    from tstarg.refimpl._lru import LRU

    made = []
    cache = LRU(2)
    for key in ("a", "b", "a", "c", "b"):
        cache.get(key, lambda k=key: made.append(k) or k.upper())
    assert made == ["a", "b", "c", "b"] and len(cache) == 2 and sorted(cache) == ["b", "c"]
