"""Fitted orders of the fast flow methods match their declared ``order`` within 0.3.

Errors are measured against the mpmath reference (independent integrator,
20 digits) on the heavy top with a cocycle Theta (drie6) and, for the
methods that allow it, with Upsilon != 0 (vier10/vier11); the order is the
least-squares slope of log(error) against log(h).

The Taylor methods (orders 12-24) leave float64's range after a few step
sizes, so their order is fitted on the generated code run in mpmath
arithmetic (it uses only + - * / and float literals) against a 90-digit
reference, on models whose float64 data are exactly the reference's data
(binary fractions, an inertia with exact inverse); taylor12 is also fitted
in float64.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from tstarg.refimpl import State, su2
from tstarg.refimpl.flows import METHODS, NumpyModel, integrate_fast, reference_trajectory
from tstarg.refimpl.flows.integrators.taylor import TaylorIntegrator

ALG = su2()
I = np.diag([1.0, 1.3, 0.5])
XI = np.array([0.2, -0.1, 0.3])
THETA = -np.einsum("k,kab->ab", XI, ALG.f)  # coboundary Theta = -xi.f (zeven3)
UPS = np.einsum(
    "l,lmn->mn", np.array([0.05, 0.1, -0.08]), ALG.f
)  # Upsilon = tau.eps (section cinq)
POT = {"kind": "gravity", "L": np.array([0.1, 0.0, 1.0]), "gamma": np.array([0.0, 0.0, -1.0])}
X0, PI0 = np.array([0.1, 0.2, 0.0]), np.array([0.3, 0.2, 1.5])
STEPS = {8: (8, 12, 16), 6: (24, 48, 96), 4: (16, 32, 64), 2: (16, 32, 64)}
STEPS_BY_NAME = {"gauss6": (12, 24, 48)}  # Gauss-6's small error constant reaches rounding sooner


def _steps(meth):
    return STEPS_BY_NAME.get(meth.name, STEPS[meth.order])


def _f64(a):
    return np.array([float(v) for v in np.ravel(a)])


@pytest.fixture(scope="module")
def references():
    out = {}
    for label, up in (("U=0", np.zeros((3, 3))), ("U!=0", UPS)):
        tr = reference_trajectory(ALG, THETA, up, I, POT, X0, PI0, [2.0], dps=20, system="body")
        out[label] = np.concatenate([_f64(tr.pi[-1]), _f64(tr.Gamma[-1])])
    tr = reference_trajectory(
        ALG, THETA, np.zeros((3, 3)), I, POT, X0, PI0, [1.0], dps=20, system="full"
    )
    out["full"] = np.concatenate([_f64(tr.x[-1]), _f64(tr.pi[-1])])
    return out


def _fit(errs, hs):
    return float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


def _applies(name, label):
    model = NumpyModel(ALG, THETA, UPS if label == "U!=0" else np.zeros((3, 3)), I, POT)
    return METHODS[name].applies(model)[0]


CASES = [
    (name, lab)
    for name in METHODS
    for lab in ("U=0", "U!=0")
    if _applies(name, lab)
    and not isinstance(METHODS[name], TaylorIntegrator)  # fitted in mpmath below
    and not METHODS[name].adaptive  # adaptive methods take a tolerance, not a step size
]
TAYLOR = [name for name in METHODS if isinstance(METHODS[name], TaylorIntegrator)]


@pytest.mark.parametrize("name,label", CASES)
def test_fitted_order_matches_declared_body(name, label, references):
    """Body system (pi, Gamma): slope of log error vs log h equals the declared order within 0.3."""
    meth = METHODS[name]
    model = NumpyModel(ALG, THETA, UPS if label == "U!=0" else np.zeros((3, 3)), I, POT)
    Ns = _steps(meth)
    errs = []
    for N in Ns:
        out = integrate_fast(model, meth, X0[:, None], PI0[:, None], 2.0, N, system="body")
        errs.append(
            np.max(
                np.abs(np.concatenate([out["pi"][:, 0], out["Gamma"][:, 0]]) - references[label])
            )
        )
    # truncation must dominate rounding: rounding model N * eps * scale (scale ~ |state| ~ 2), x 100 margin
    assert min(errs) > 100 * max(Ns) * np.finfo(float).eps * 2
    assert abs(_fit(errs, 2.0 / np.array(Ns)) - meth.order) <= 0.3, errs


@pytest.mark.parametrize("name", ["dop853", "rkmk4", "rkmk8", "gauss4", "splitting4", "splitting6"])
def test_fitted_order_matches_declared_configuration(name, references):
    """Full state (x, pi) with re-basing / group updates: fitted order == declared within 0.3."""
    meth = METHODS[name]
    model = NumpyModel(ALG, THETA, np.zeros((3, 3)), I, POT)
    Ns = tuple(max(1, n // 2) for n in _steps(meth))
    errs = []
    for N in Ns:
        out = integrate_fast(model, meth, X0[:, None], PI0[:, None], 1.0, N, system="full")
        errs.append(
            np.max(np.abs(np.concatenate([out["x"][:, 0], out["pi"][:, 0]]) - references["full"]))
        )
    assert min(errs) > 100 * max(Ns) * np.finfo(float).eps * 2  # rounding model as above
    assert abs(_fit(errs, 1.0 / np.array(Ns)) - meth.order) <= 0.3, errs


def test_fitted_order_taylor12_float64(references):
    """taylor12 in float64 on the body system: slope of log error vs log h equals 12 within 0.3."""
    meth = METHODS["taylor12"]
    model = NumpyModel(ALG, THETA, np.zeros((3, 3)), I, POT)
    Ns = (6, 8, 10, 12)
    errs = []
    for N in Ns:
        out = integrate_fast(model, meth, X0[:, None], PI0[:, None], 2.0, N, system="body")
        errs.append(
            np.max(
                np.abs(np.concatenate([out["pi"][:, 0], out["Gamma"][:, 0]]) - references["U=0"])
            )
        )
    assert min(errs) > 100 * max(Ns) * np.finfo(float).eps * 2  # rounding model as above
    assert abs(_fit(errs, 2.0 / np.array(Ns)) - meth.order) <= 0.3, errs


# binary-exact data: I^-1 = diag(1, 1/2, 2) and every other number a binary fraction, so the generated
# code's float literals are the reference's exact inputs; "lagrange" has a constant component (pi_3,
# I_1 = I_2 and L on the axis), which the generated code drops from its Cauchy products
EXACT = {
    "asymmetric gyrostat": (
        np.diag([1.0, 2.0, 0.5]),
        np.array([0.25, -0.125, 0.375]),
        np.array([0.125, 0.0, 1.0]),
    ),
    "lagrange": (np.diag([1.0, 1.0, 0.5]), np.zeros(3), np.array([0.0, 0.0, 1.0])),
}
X0E, PI0E = np.array([0.125, 0.25, 0.0]), np.array([0.375, 0.25, 1.5])


@pytest.fixture(scope="module")
def exact_references():
    out = {}
    for label, (inertia, xi, L) in EXACT.items():
        theta = -np.einsum("k,kab->ab", xi, ALG.f)
        pot = {"kind": "gravity", "L": L, "gamma": np.array([0.0, 0.0, -1.0])}
        tr = reference_trajectory(
            ALG, theta, np.zeros((3, 3)), inertia, pot, X0E, PI0E, [0, 1.0], dps=90, system="body"
        )
        out[label] = (
            NumpyModel(ALG, theta, np.zeros((3, 3)), inertia, pot),
            list(tr.pi[0]) + list(tr.Gamma[0]),
            list(tr.pi[-1]) + list(tr.Gamma[-1]),
        )
    return out


@pytest.mark.parametrize("label", list(EXACT))
@pytest.mark.parametrize("name", TAYLOR)
def test_fitted_order_taylor_high_precision(name, label, exact_references):
    """Taylor methods: the generated step run in 100-digit arithmetic; slope of log error vs log h equals the
    declared order within 0.3 (errors 1e-18..1e-52, far above the 90-digit reference's own error)."""
    from tstarg.refimpl._taylor import scalar_taylor_integrator

    meth = METHODS[name]
    model, y0, y1 = exact_references[label]
    assert np.all(model.Iinv == np.linalg.inv(model.inertia))  # the literals are exact
    run = scalar_taylor_integrator(model, meth.order)
    Ns = (24, 34, 48, 68)
    with mpmath.workdps(100):
        errs = [
            float(max(abs(a - b) for a, b in zip(run(y0, mpmath.mpf(1) / N, N), y1))) for N in Ns
        ]
    # the reference is good to ~1e-90 (GBS at 90 digits), arithmetic to 1e-100 per operation: the smallest
    # error must stay far above both
    assert min(errs) > 1e-80, errs
    assert abs(_fit(errs, 1.0 / np.array(Ns)) - meth.order) <= 0.3, errs


KUTTA38 = '''"""Kutta's 3/8 rule: an explicit RK method of order 4 (the worked example of a new integrator)."""

import numpy as np

from tstarg.refimpl._integrators import ExplicitRK
from tstarg.refimpl.flows.integrators.rk import ExplicitRKIntegrator

A = np.zeros((4, 4))
A[1, 0] = 1 / 3
A[2, 0], A[2, 1] = -1 / 3, 1.0
A[3, 0], A[3, 1], A[3, 2] = 1.0, -1.0, 1.0
TABLEAU = (A, np.array([1.0, 3.0, 3.0, 1.0]) / 8, np.array([0.0, 1 / 3, 2 / 3, 1.0]))

INTEGRATORS = [ExplicitRKIntegrator("kutta38", ExplicitRK("kutta38", TABLEAU, 4))]
'''


def test_new_integrator_is_one_file_with_its_order(tmp_path, monkeypatch, references):
    """A new integrator is one module in the integrators package: planted in a package of its own, the
    registry finds it and its fitted order is the declared 4 (Kutta's 3/8 rule)."""
    import importlib
    import sys

    from tstarg.refimpl.flows.registry import _discover

    pkg = tmp_path / "planted_integrators"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "kutta38.py").write_text(KUTTA38)
    monkeypatch.syspath_prepend(str(tmp_path))
    found = _discover(importlib.import_module("planted_integrators"))
    assert list(found) == ["kutta38"]
    meth = found["kutta38"]
    model = NumpyModel(ALG, THETA, np.zeros((3, 3)), I, POT)
    Ns = (16, 32, 64)
    errs = []
    for N in Ns:
        out = meth.integrate(model, State(X0[:, None], PI0[:, None]), 2.0, steps=N, system="body")
        y = np.concatenate([out.pi[:, 0], out.Gamma[:, 0]])
        errs.append(np.max(np.abs(y - references["U=0"])))
    sys.modules.pop("planted_integrators.kutta38", None)
    assert abs(_fit(errs, 2.0 / np.array(Ns)) - meth.order) <= 0.3, errs
