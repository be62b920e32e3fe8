"""The Python face for notebooks (refimpl/notebook.py, Model.su2 / Model.from_catalogue): models
built from the paper's constants equal the ones written out by hand, bad constants are refused by
name, and the trajectory and bracket helpers give what the protocol and the scene route give."""

from __future__ import annotations

import doctest

import numpy as np
import pytest

from tstarg.refimpl import Model, bracket, catalogue, notebook, protocol_args, trajectory
from tstarg.refimpl import model as model_module
from tstarg.refimpl.fast import implementation as fast
from tstarg.refimpl.flows import parse_scene, plan, run_scene


def _eps() -> np.ndarray:
    e = np.zeros((3, 3, 3))
    e[0, 1, 2] = e[1, 2, 0] = e[2, 0, 1] = 1.0
    e[0, 2, 1] = e[2, 1, 0] = e[1, 0, 2] = -1.0
    return e


def test_su2_from_the_papers_constants():
    xi, tau = np.array([0.1, -0.2, 0.3]), np.array([0.05, 0.1, -0.05])
    m = Model.su2(xi=xi, tau=tau, inertia=[1.0, 2.0, 3.0])
    eps = _eps()
    # section cinq written out: Theta_ab = -xi_k eps_kab, Upsilon^mn = tau_l eps_lmn
    theta = np.array(
        [[-sum(xi[k] * eps[k, a, b] for k in range(3)) for b in range(3)] for a in range(3)]
    )
    ups = np.array(
        [[sum(tau[l] * eps[l, a, b] for l in range(3)) for b in range(3)] for a in range(3)]
    )
    assert np.array_equal(m.theta, theta) and np.array_equal(m.upsilon, ups)
    assert np.array_equal(m.inertia, np.diag([1.0, 2.0, 3.0])) and m.potential is None
    assert m.su2 is True and np.allclose(m.xi, xi)  # on an instance: the cached predicate
    assert repr(m) == (
        "Model(su(2), n=3, inertia=diag(1, 2, 3), Theta=-xi.f with xi=(0.1, -0.2, 0.3), "
        "Upsilon=tau.eps with tau=(0.05, 0.1, -0.05), potential=None)"
    )


def test_catalogue_models_and_gravity():
    m = Model.from_catalogue("se(3)", inertia=[1, 1, 2, 1, 1, 1])
    assert np.array_equal(m.f, catalogue("se(3)").f) and m.theta_zero and m.upsilon_zero
    assert m.su2 is False
    g = Model.su2(inertia=[1, 1, 0.5], potential={"L": [0, 0, 1.0], "gamma": [0, 0, -1.0]})
    assert g.gravity and "gravity(L=(0, 0, 1), gamma=(0, 0, -1))" in repr(g)


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"xi": [1.0, 0.0, 0.0], "theta": np.zeros((3, 3))}, "not both"),
        ({"tau": [1.0, 0.0, 0.0], "upsilon": np.zeros((3, 3))}, "not both"),
        ({"xi": [1.0, 0.0]}, r"xi must have shape \(3,\)"),
        ({"inertia": [1.0, -2.0, 3.0]}, "inertia"),
        ({"theta": np.ones((3, 3))}, "theta"),
    ],
)
def test_bad_constants_are_refused_by_name(kw, match):
    with pytest.raises(ValueError, match=match):
        Model.su2(**kw)


def test_tau_is_only_for_su2():
    with pytest.raises(ValueError, match="tau"):
        Model.from_catalogue("se(3)", tau=[0.1, 0.0, 0.0])


def test_bracket_and_trajectory_agree_with_the_protocol_and_the_scene_route():
    m = Model.su2(xi=[0.1, -0.2, 0.3], tau=[0.05, 0.1, -0.05], inertia=[1.0, 2.0, 3.0])
    x, pi = np.array([0.1, 0.0, 0.0]), np.array([0.3, 0.2, 1.0])
    f, theta, ups, inertia, pot = protocol_args(m)
    assert np.array_equal(bracket(m, x, pi), fast.poisson_tensor(f, theta, ups, x, pi))
    f[0, 0, 0] = 99.0  # the arrays handed out are copies: the model is untouched
    assert m.f[0, 0, 0] == 0.0
    tr = trajectory(m, x, pi, 1.0, samples=5, tol=1e-10)
    scene = parse_scene(
        {
            "algebra": "su(2)",
            "xi": [0.1, -0.2, 0.3],
            "tau": [0.05, 0.1, -0.05],
            "inertia_diagonal": [1.0, 2.0, 3.0],
            "x0": x.tolist(),
            "pi0": pi.tolist(),
            "t_end": 1.0,
            "samples": 5,
            "tol": 1e-10,
            "outputs": ["pi", "x", "energy"],
        }
    )
    p = plan(scene)
    out = run_scene(scene, p)
    assert tr.plan.method == p.method and tr.path == out["path"]
    assert np.array_equal(tr.pi, out["pi"]) and np.array_equal(tr.x, out["x"])
    assert "5 samples in [0, 1], 1 trajectory, n=3" in repr(tr)
    with pytest.raises(TypeError, match="Model"):
        trajectory("su(2)", x, pi, 1.0)


def test_docstring_examples_run():
    for mod in (model_module, notebook):
        res = doctest.testmod(mod, optionflags=doctest.ELLIPSIS)
        assert res.attempted > 0 and res.failed == 0, mod.__name__
