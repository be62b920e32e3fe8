"""Issue 15, scene files: budgets before any work, degenerate or off-chart starts named, malformed
values refused by key; Hypothesis fuzzing of the loader."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tstarg.refimpl.scenes import MAX_POINTS, MAX_SAMPLES, Scene, load_scene, parse_scene

BASE = {
    "name": "hardening",
    "algebra": "su(2)",
    "inertia_diagonal": [1.0, 2.0, 3.0],
    "x0": [0.1, 0.0, 0.0],
    "pi0": [0.3, 0.2, -0.4],
    "t_end": 1.0,
    "samples": 5,
}


def _scene(**patch) -> dict:
    d = dict(BASE)
    for k, v in patch.items():
        if v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return d


@pytest.mark.parametrize(
    "patch, needle",
    [
        ({"t_end": 1e12}, "t_end.*budget"),
        ({"samples": 10**9}, "samples"),
        ({"samples": MAX_SAMPLES + 1}, "samples"),
        ({"samples": 1e9}, "samples"),
        ({"samples": True}, "samples"),
        ({"tol": 1e-20}, "tol"),
        ({"tol": "1e-9"}, "tol"),
        ({"t_end": "1e3"}, "t_end"),
        ({"x0": ["0", "0", "0"]}, "x0"),
        ({"pi0": [[0.0, 0.0, 1e8]]}, "pi0.*rotates too fast"),
        (
            {
                "x0": [[0.0, 0.0, 0.0]] * (MAX_POINTS + 1),
                "pi0": [[0.1, 0.2, 0.3]] * (MAX_POINTS + 1),
            },
            "budget",
        ),
        ({"inertia_diagonal": [1.0, 1.0, 1e-310]}, "inertia"),
        ({"inertia_diagonal": [1.0, 1.0, 1e-14]}, "ill-conditioned"),
        ({"method": ["dop853"]}, "method"),
        ({"method": "bogus"}, "method"),
        ({"outputs": "pi"}, "outputs"),
        ({"outputs": [1, 2]}, "outputs"),
        ({"algebra": 3}, "algebra"),
        ({"name": ""}, "name"),
        ({"name": 5}, "name"),
        ({"name": "x" * 1000}, "name"),
        ({"x0": [0.0, 0.0, 7.0]}, "outside the chart"),
        ({"x0": [0.0, 0.0, 1e300]}, "outside the chart"),
    ],
)
def test_bad_scenes_are_refused_before_any_work(patch, needle):
    with pytest.raises(ValueError, match=needle):
        parse_scene(_scene(**patch))


def test_degenerate_start_is_named_not_a_singular_matrix():
    """A start on Pi_1 gave numpy's "Singular matrix". su(2) with tau: C1 = 1 - pi.tau = 0 at
    pi = tau / |tau|^2 (section cinq), exactly representable here."""
    tau = [0.25, -0.5, 0.5]  # |tau|^2 = 9/16
    pi = [t / (9 / 16) for t in tau]
    assert 1 - sum(p * t for p, t in zip(pi, tau)) == 0.0
    with pytest.raises(ValueError, match=r"starting point 1 .*degenerate set Pi_1"):
        parse_scene(_scene(tau=tau, pi0=[[0.1, 0.2, 0.3], pi], x0=[0.0, 0.0, 0.0]))


def test_good_scene_still_loads():
    sc = parse_scene(_scene())
    assert isinstance(sc, Scene) and sc.samples == 5 and sc.x0.shape == (1, 3)


def test_load_scene_bad_files(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_bytes(b"\xff\xfe not utf8 = 1")
    with pytest.raises(ValueError, match="not valid TOML"):
        load_scene(p)
    with pytest.raises(ValueError, match="cannot read"):
        load_scene(tmp_path / "missing.toml")


# ------------------------------------------------------------------ fuzzing
JUNK = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**20), 10**20),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4),
    st.lists(st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3), max_size=3),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
    st.just("...toml"),
    st.just("__import__('os').getpid()"),
)
KEYS = sorted(
    set(BASE)
    | {"tau", "xi", "theta", "upsilon", "inertia", "potential", "tol", "method", "outputs", "f"}
)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(st.sampled_from(KEYS), JUNK, min_size=1, max_size=3))
def test_fuzz_scene_loader(patch):
    """Any malformed value: a ValueError, or a valid scene within every budget."""
    d = dict(BASE)
    d.update(patch)
    try:
        sc = parse_scene(d)
    except ValueError as exc:
        assert str(exc)
        return
    assert 0 < sc.t_end <= 1e4 and 2 <= sc.samples <= MAX_SAMPLES and sc.tol >= 1e-14
    assert all(
        np.all(np.isfinite(a)) for a in (sc.f, sc.theta, sc.upsilon, sc.inertia, sc.x0, sc.pi0)
    )
    assert isinstance(sc.name, str) and sc.name


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(["t_end", "samples", "tol", "x0", "pi0", "name", "method"]), JUNK)
def test_fuzz_scene_files(tmp_path_factory, key, junk):
    """The same through TOML text (what a user writes); values TOML cannot hold are skipped."""
    d = dict(BASE)
    d[key] = junk
    lines = []
    for k, v in d.items():
        if v is None or (isinstance(v, float) and math.isnan(v)) or isinstance(v, dict):
            continue
        lines.append(f"{k} = {_toml(v)}")
    text = "\n".join(lines) + "\n"
    try:
        tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return
    p = tmp_path_factory.mktemp("s") / "scene.toml"
    p.write_text(text)
    try:
        load_scene(p)
    except ValueError as exc:
        assert str(exc)


def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, float):
        return "inf" if v == math.inf else ("-inf" if v == -math.inf else repr(v))
    if isinstance(v, list):
        return (
            "["
            + ", ".join(_toml(e) for e in v if not (isinstance(e, float) and math.isnan(e)))
            + "]"
        )
    return repr(v)
