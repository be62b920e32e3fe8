"""Fitted orders of the fast flow methods match their declared ``order`` within 0.3.

Errors are measured against the mpmath reference (independent integrator,
20 digits) on the heavy top with a cocycle Theta (drie6) and, for the
methods that allow it, with Upsilon != 0 (vier10/vier11); the order is the
least-squares slope of log(error) against log(h).
"""

from __future__ import annotations

import numpy as np
import pytest

from refimpl import su2
from refimpl.flows import METHODS, NumpyModel, integrate_fast, reference_trajectory

ALG = su2()
I = np.diag([1.0, 1.3, 0.5])
XI = np.array([0.2, -0.1, 0.3])
THETA = -np.einsum("k,kab->ab", XI, ALG.f)                        # coboundary Theta = -xi.f (zeven3)
UPS = np.einsum("l,lmn->mn", np.array([0.05, 0.1, -0.08]), ALG.f)  # Upsilon = tau.eps (section cinq)
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
    tr = reference_trajectory(ALG, THETA, np.zeros((3, 3)), I, POT, X0, PI0, [1.0], dps=20, system="full")
    out["full"] = np.concatenate([_f64(tr.x[-1]), _f64(tr.pi[-1])])
    return out


def _fit(errs, hs):
    return float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


CASES = [(name, lab) for name in METHODS for lab in ("U=0", "U!=0")
         if not (lab == "U!=0" and METHODS[name].kind in ("splitting", "scalar"))]


@pytest.mark.parametrize("name,label", CASES)
def test_fitted_order_matches_declared_body(name, label, references):
    """Body system (pi, Gamma): slope of log error vs log h equals the declared order within 0.3."""
    meth = METHODS[name]
    model = NumpyModel(ALG, THETA, UPS if label == "U!=0" else np.zeros((3, 3)), I, POT)
    Ns = _steps(meth)
    errs = []
    for N in Ns:
        out = integrate_fast(model, meth, X0[:, None], PI0[:, None], 2.0, N, system="body")
        errs.append(np.max(np.abs(np.concatenate([out["pi"][:, 0], out["Gamma"][:, 0]]) - references[label])))
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
        errs.append(np.max(np.abs(np.concatenate([out["x"][:, 0], out["pi"][:, 0]]) - references["full"])))
    assert min(errs) > 100 * max(Ns) * np.finfo(float).eps * 2  # rounding model as above
    assert abs(_fit(errs, 1.0 / np.array(Ns)) - meth.order) <= 0.3, errs
