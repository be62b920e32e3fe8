"""Scenes: the planner skips what a scene does not need, bad scene files are rejected by key and shape,
and ``tstarg run`` writes its outputs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import tstarg.refimpl.flows._common as flows_common
from tstarg.refimpl.flows import load_scene, parse_scene, plan, run_scene

SCENES = sorted((Path(__file__).resolve().parent.parent / "refimpl" / "scenes").glob("*.toml"))
EPS = float(np.finfo(float).eps)
BASE = {
    "algebra": "su(2)",
    "inertia_diagonal": [1.0, 2.0, 3.0],
    "x0": [0.1, 0.0, 0.0],
    "pi0": [0.4, -0.3, 1.1],
    "t_end": 2.0,
    "samples": 5,
    "tol": 1e-8,
    "outputs": ["pi", "energy"],
}


def test_example_scenes_parse_and_cover_the_issue():
    """The six example scenes load; among them: Theta != 0, Upsilon != 0, gravity, a solvable algebra."""
    scenes = [load_scene(p) for p in SCENES]
    assert len(scenes) >= 6
    assert any(s.potential is not None for s in scenes)
    assert any(np.any(s.upsilon) for s in scenes)
    assert any(np.any(s.theta) for s in scenes)
    assert any(s.algebra is not None and "solvable" in s.algebra.tags for s in scenes)


def test_no_configuration_integrated_when_x_not_requested(monkeypatch):
    """A gravity scene asking only for body quantities integrates (pi, Gamma): the configuration frame
    L(g, e) is never evaluated."""
    sc = parse_scene({**BASE, "potential": {"L": [0, 0, 1.0], "gamma": [0, 0, -1.0]}})
    p = plan(sc)
    assert p.system == "body"
    assert any("Euler-Poisson" in s for s in p.skipped)

    def boom(*a, **k):
        raise AssertionError("configuration frame evaluated")

    monkeypatch.setattr(flows_common, "_frame_L", boom)
    out = run_scene(sc, p)
    assert "x" not in out and out["Gamma"].shape == (5, 1, 3)


def test_configuration_integrated_when_x_requested():
    """Asking for x switches the plan to the full state (x, pi)."""
    sc = parse_scene({**BASE, "outputs": ["pi", "x"]})
    p = plan(sc)
    assert p.system == "full"
    assert run_scene(sc, p)["x"].shape == (5, 1, 3)


def _count_solves(monkeypatch):
    calls = {"n": 0}
    real = np.linalg.solve

    def counting(*a, **k):
        calls["n"] += 1
        return real(*a, **k)

    monkeypatch.setattr(np.linalg, "solve", counting)
    return calls


def test_no_phi_solve_when_upsilon_zero(monkeypatch):
    """Upsilon = 0: the plan says no Phi solve, and the run performs no linear solve at all."""
    sc = parse_scene(BASE)
    p = plan(sc)
    assert not p.phi_solve and any("Phi solve" in s for s in p.skipped)
    calls = _count_solves(monkeypatch)
    run_scene(sc, p)
    assert calls["n"] == 0


def test_phi_solved_when_upsilon_nonzero(monkeypatch):
    """Upsilon != 0 (control): Phi is solved. With numba the planner takes the compiled rational
    Taylor method (its Phi solve is the series recurrence inside the kernel), else Gauss6; a scene
    that asks for Gauss6 solves by numpy. The two runs agree within the scene tolerance at every
    sample (error model: each within tol of the flow, so 2 tol apart, plus 64 eps |pi| of rounding)."""
    from tstarg.refimpl import _compiled_taylor

    sc = parse_scene({**BASE, "tau": [0.05, -0.1, 0.08]})
    p = plan(sc)
    assert p.phi_solve
    assert p.method == ("taylor-rational" if _compiled_taylor.HAVE_NUMBA else "gauss6")
    got = run_scene(sc, p)
    sg = parse_scene({**BASE, "tau": [0.05, -0.1, 0.08], "method": "gauss6"})
    calls = _count_solves(monkeypatch)
    want = run_scene(sg, plan(sg))
    assert calls["n"] > 0
    assert np.all(np.isfinite(got["pi"]))
    tol = sc.tol
    assert np.max(np.abs(got["pi"] - want["pi"])) <= 2 * tol + 64 * EPS * np.max(np.abs(want["pi"]))


def test_planned_run_meets_the_tolerance():
    """The planned run (whatever method the planner picks: adaptive Taylor, or fixed steps) meets
    the scene tolerance at every sample against the mpmath reference (20 digits, an independent
    integrator): |pi - pi_ref| <= 10 tol (the planner's contract is tol per sample; 10x margin
    for the error estimate's own slack) + 64 eps |pi| (rounding of the samples)."""
    from tstarg.refimpl import catalogue
    from tstarg.refimpl.flows import reference_trajectory

    pot = {"kind": "gravity", "L": np.array([0, 0, 1.0]), "gamma": np.array([0, 0, -1.0])}
    sc = parse_scene(
        {
            **BASE,
            "potential": {"L": [0, 0, 1.0], "gamma": [0, 0, -1.0]},
            "t_end": 10.0,
            "samples": 11,
        }
    )
    p = plan(sc)
    out = run_scene(sc, p)
    ref = reference_trajectory(
        catalogue("su(2)"),
        np.zeros((3, 3)),
        np.zeros((3, 3)),
        np.diag(BASE["inertia_diagonal"]),
        pot,
        np.array(BASE["x0"]),
        np.array(BASE["pi0"]),
        [str(v) for v in np.linspace(0.0, 10.0, 11)],
        dps=20,
        system="body",
    )
    pr = np.array(ref.pi, dtype=float)
    got = out["pi"][:, 0, :]
    eps = np.finfo(float).eps
    err = np.max(np.abs(got - pr))
    assert err <= 10 * sc.tol + 64 * eps * np.max(np.abs(pr)), (p.method, err)


@pytest.mark.parametrize(
    "patch,needle",
    [
        ({"colour": 1}, "colour"),
        ({"x0": [0.1, 0.0]}, "'x0' must have shape (3,)"),
        ({"inertia_diagonal": [[1.0]]}, "'inertia_diagonal' must have shape (3,)"),
        ({"theta": [[0.0, 1.0], [-1.0, 0.0]]}, "'theta' must have shape (3, 3)"),
        ({"potential": {"L": [0, 0, 1.0], "gamma": [0, 0, -1.0], "mass": 2}}, "mass"),
        ({"t_end": -1.0}, "t_end"),
        ({"tol": float("nan")}, "tol"),
        ({"outputs": ["pi", "spin"]}, "spin"),
    ],
)
def test_bad_scenes_are_rejected_naming_key_and_shape(patch, needle):
    """Unknown keys and wrong shapes raise ValueError naming the key (and the expected shape)."""
    with pytest.raises(ValueError, match=__import__("re").escape(needle)):
        parse_scene({**BASE, **patch})


def test_run_command_writes_outputs(tmp_path):
    """`tstarg run SCENE` writes npz, CSV and PNG, and prints the plan."""
    from tstarg.reports.cli import main

    scene = tmp_path / "s.toml"
    scene.write_text(
        'algebra = "su(2)"\ninertia_diagonal = [1.0, 2.0, 3.0]\nx0 = [0.0, 0.0, 0.0]\n'
        'pi0 = [0.4, -0.3, 1.1]\nt_end = 2.0\nsamples = 11\noutputs = ["pi", "energy", "casimirs"]\n'
    )
    assert main(["run", str(scene), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    for name in ("trajectory.npz", "trajectory.csv", "trajectory.png"):
        assert (tmp_path / "out" / name).stat().st_size > 0
    data = np.load(tmp_path / "out" / "trajectory.npz")
    assert data["pi"].shape == (11, 1, 3)


def test_run_command_rejects_bad_scene(tmp_path, capsys):
    """`tstarg run` on a scene with an unknown key exits with status 2 and names the key."""
    from tstarg.reports.cli import main

    scene = tmp_path / "bad.toml"
    scene.write_text(
        'algebra = "su(2)"\ninertia_diagonal = [1.0, 2.0, 3.0]\nx0 = [0.0, 0.0, 0.0]\n'
        "pi0 = [0.4, -0.3, 1.1]\nt_end = 2.0\nspin = 3\n"
    )
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) == 2
    assert "spin" in capsys.readouterr().err
