"""A failed check shows its input, rendered by tstarg from the drawn values (issue 19, deliverable 2).

Independent of the installed Hypothesis: 6.170 attaches the falsifying example as an exception
note and prints nothing, and its shrink-time-limit warning is not an example. Run these under the
oldest supported release too (pyproject's lower bound), e.g.::

    pip install --no-deps --target /tmp/hyp_old "hypothesis==6.100.0"
    PYTHONPATH=/tmp/hyp_old:$PYTHONPATH python -m pytest tests/test_runner_example.py
"""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from tstarg.properties import runner
from tstarg.properties.runner import decode, encode, limits, note, run_property
from tstarg.refimpl import su2
from tstarg.reports import cli

EPS = float(np.finfo(float).eps)
SU2 = su2()


def model(x, pi):
    z = np.zeros((3, 3))
    return ("su(2)", SU2.f, z, z, np.asarray(x, dtype=float), np.asarray(pi, dtype=float))


# ------------------------------------------------------------------ the runner's own rendering
def planted_body(ex):
    """ratio = |pi_0| / 1e-3: fails once |pi_0| > 1e-3; records expected and got like a certification body."""
    (_name, _f, _theta, _ups, x, pi), _t = ex
    expected = np.outer(x, pi)
    got = expected.copy()
    got[1, 2] += pi[0]
    tol = 1e-3
    note(expected=expected, got=got, tolerance=tol)
    return float(np.max(np.abs(got - expected))) / tol, None


vec = hnp.arrays(float, 3, elements=st.floats(-2, 2))
STRAT = st.tuples(st.builds(model, vec, vec), st.sampled_from([0.1, 0.7]))


def test_failing_example_is_rendered_from_the_drawn_values():
    res = run_property("planted", "vier9", planted_body, STRAT, max_examples=60, seed=0)
    assert not res.passed
    ex = res.extra["example"]
    (name, f, _theta, _ups, x, pi), t = decode(ex["values"])
    assert name == "su(2)" and np.array_equal(f, SU2.f) and t in (0.1, 0.7)
    assert abs(pi[0]) > 1e-3  # it is a failing example: ratio = |pi_0| / 1e-3 > 1
    worst = ex["worst_entry"]
    assert worst["index"] == [1, 2]  # the planted entry
    assert worst["got"] - worst["expected"] == pytest.approx(
        pi[0], abs=4 * EPS * (1 + abs(x[1] * pi[2]))
    )
    assert worst["tolerance"] == 1e-3 and worst["ratio"] == pytest.approx(
        abs(pi[0]) / 1e-3, rel=4 * EPS
    )
    text = res.falsifying_example
    for part in (
        "algebra = su(2) (dimension 3)",
        f"x = {x.tolist()!r}",
        f"pi = {pi.tolist()!r}",
        f"t = {t!r}",
        "worst entry result[1,2]",
        "tolerance 1.000e-03",
    ):
        assert part in text, (part, text)
    json.dumps(res.to_json())  # the data is JSON


def test_shrink_time_limit_warning_is_never_the_example(monkeypatch):
    """Hypothesis' 'spent more than five minutes ... shrink' warning goes to its own field."""
    engine = pytest.importorskip("hypothesis.internal.conjecture.engine")
    if not hasattr(engine, "MAX_SHRINKING_SECONDS"):
        pytest.skip("this Hypothesis has no shrink time limit constant")
    monkeypatch.setattr(engine, "MAX_SHRINKING_SECONDS", 0)
    res = run_property("planted", "vier9", planted_body, STRAT, max_examples=60, seed=0)
    assert not res.passed
    assert "WARNING" not in res.falsifying_example and "five minutes" not in res.falsifying_example
    assert res.falsifying_example.startswith(
        "falsifying example (drawn values, rendered by tstarg)"
    )
    assert "pi = [" in res.falsifying_example


def test_sys_exit_in_a_check_is_a_failure_not_an_exit():
    def body(ex):
        if ex > 5:
            raise SystemExit(0)
        return 0.0, None

    res = run_property("exits", "-", body, st.integers(0, 100), max_examples=50, seed=0)
    assert not res.passed and "sys.exit(0)" in res.detail
    assert decode(res.extra["example"]["values"]) == 6  # shrunk to the smallest failing integer


def test_nan_ratio_fails():
    res = run_property(
        "nan", "-", lambda ex: (math.nan, None), st.integers(0, 3), max_examples=5, seed=0
    )
    assert not res.passed and res.worst_ratio == math.inf


@given(
    st.recursive(
        st.none()
        | st.booleans()
        | st.integers()
        | st.floats()
        | st.text(max_size=5)
        | hnp.arrays(float, hnp.array_shapes(max_dims=3, max_side=3)),
        lambda c: (
            st.lists(c, max_size=3)
            | st.tuples(c, c)
            | st.dictionaries(st.text(max_size=3), c, max_size=2)
        ),
        max_leaves=8,
    )
)
def test_encode_decode_round_trip(value):
    """Replay needs the example back exactly: floats (NaN, inf, -0.0), arrays, tuples, dicts."""
    back = decode(json.loads(json.dumps(encode(value))))

    def same(a, b):
        if isinstance(a, np.ndarray):
            return (
                isinstance(b, np.ndarray)
                and a.shape == b.shape
                and a.dtype == b.dtype
                and np.array_equal(
                    a.view(np.uint64) if a.dtype == float and a.size else a,
                    b.view(np.uint64) if b.dtype == float and b.size else b,
                )
            )
        if isinstance(a, float):
            return isinstance(b, float) and (
                a == b
                and math.copysign(1, a) == math.copysign(1, b)
                or math.isnan(a)
                and math.isnan(b)
            )
        if isinstance(a, (list, tuple)):
            return type(a) is type(b) and len(a) == len(b) and all(same(p, q) for p, q in zip(a, b))
        if isinstance(a, dict):
            return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
        return type(a) is type(b) and a == b

    assert same(value, back)


# ------------------------------------------------------------------ budgets
def test_examples_over_budget_are_drawn_again_and_counted():
    def body(ex):
        if ex % 2:
            time.sleep(5)  # interrupted at 0.2 s
        return 0.0, None

    with limits(example_seconds=0.2):
        res = run_property("slow odd", "-", body, st.integers(0, 40), max_examples=10, seed=0)
    assert res.passed and res.examples >= 1 and res.extra["over_budget"] >= 1


def test_all_examples_over_budget_is_not_a_pass():
    def body(ex):
        time.sleep(5)
        return 0.0, None

    with limits(example_seconds=0.1):
        res = run_property("always slow", "-", body, st.integers(0, 40), max_examples=3, seed=0)
    assert not res.passed and res.examples == 0 and "nothing verified" in res.detail


def test_shrinking_stops_at_its_budget_with_a_failing_example():
    def body(ex):
        time.sleep(0.02)
        return (2.0 if ex > 10 else 0.0), None

    with limits(shrink_seconds=0.05):
        res = run_property("shrink", "-", body, st.integers(0, 10**9), max_examples=50, seed=0)
    assert (
        not res.passed and decode(res.extra["example"]["values"]) > 10
    )  # a failing example, maybe not minimal
    if "shrinking stopped" in res.detail:
        assert "budget" in res.detail


def test_run_budget_used_up_fails_later_checks():
    with limits(run_seconds=0.05):
        time.sleep(0.1)
        res = run_property(
            "late", "-", lambda ex: (0.0, None), st.integers(), max_examples=5, seed=0
        )
    assert not res.passed and res.examples == 0 and "nothing verified" in res.detail


def test_time_limit_nests_and_names_the_expired_block():
    with (
        pytest.raises(runner.TimeLimitExceeded) as info,
        runner.time_limit(5, "outer"),
        runner.time_limit(0.1, "inner"),
    ):
        time.sleep(2)
    assert info.value.what == "inner"
    with (
        pytest.raises(runner.TimeLimitExceeded) as info,
        runner.time_limit(0.1, "outer"),
        runner.time_limit(5, "inner"),
    ):
        time.sleep(2)
    assert info.value.what == "outer"
    with pytest.raises(ValueError, match="must be positive"), runner.time_limit(0, "zero"):
        pass


# ------------------------------------------------------------------ through tstarg certify
def test_planted_certificate_names_algebra_point_and_worst_entry(tmp_path, capfd):
    """tests/meta/targets.py:planted multiplies P[0, n] and P[n, 0] by 1 + 1e-6. (capfd: certify
    runs the target in a supervised child process, which writes to the inherited file descriptors.)"""
    rc = cli.main(
        [
            "certify",
            "tests.meta.targets:planted",
            "--check",
            "poisson_tensor.reference",
            "--profile",
            "dev",
            "--max-examples",
            "3",
            "--workers",
            "1",
            "--shrink-seconds",
            "1",
            "--out",
            str(tmp_path),
        ]
    )
    assert rc == 1
    cert = json.loads((tmp_path / "certificate.json").read_text())
    failed = [c for c in cert["checks"] if not c["passed"]]
    assert failed
    for c in failed:
        ex = c["extra"]["example"]
        name, f, _theta, _ups, x, pi = decode(ex["values"])
        n = f.shape[0]
        text = c["falsifying_example"]
        assert f"algebra = {name} (dimension {n})" in text and f"x = {x.tolist()!r}" in text
        assert f"pi = {pi.tolist()!r}" in text and "Theta = " in text and "Upsilon = " in text
        w = ex["worst_entry"]
        assert sorted(w["index"]) == [0, n], w  # the planted entry (or its antisymmetric partner)
        # got = P(1 + 1e-6) with P from refimpl.fast; fast's own error stays within the certificate's
        # tolerance model C n eps cond frame scale (it passes certification), here w["tolerance"]
        assert abs(w["got"] - w["expected"] * (1 + 1e-6)) <= w["tolerance"] + 4 * EPS * abs(
            w["expected"]
        )
        assert f"worst entry P[{w['index'][0]},{w['index'][1]}]" in text and "expected" in text
        assert ex["replay"].endswith(f"--replay {tmp_path / 'certificate.json'}")
    md = (tmp_path / "certificate.md").read_text()
    assert "algebra = " in md and "worst entry P[" in md
    capfd.readouterr()
    assert (
        cli.main(
            [
                "certify",
                "tests.meta.targets:planted",
                "--replay",
                str(tmp_path / "certificate.json"),
            ]
        )
        == 1
    )
    out = capfd.readouterr().out
    assert out.count("FAIL on the stored example") == len(failed)


def test_error_while_drawing_is_reported_as_such():
    """A strategy that raises: no example exists, and the report says where it came from."""

    def boom(x):
        raise np.linalg.LinAlgError("SVD did not converge")

    res = run_property(
        "draw fails", "-", lambda ex: (0.0, None), st.integers().map(boom), max_examples=3, seed=0
    )
    assert not res.passed and "LinAlgError" in res.detail
    assert "while drawing an example" in res.falsifying_example and "boom" in res.falsifying_example


@pytest.mark.parametrize("noted", [22.5, None])
def test_a_check_that_raises_never_reports_a_ratio_within_tolerance(noted):
    """A body that raises on a bad example (its own assertion, not a returned ratio) fails the check,
    and the check's worst ratio -- "the largest error / tolerance seen" -- is that example's noted
    ratio, or inf when it noted none; never the passing examples' maximum (here 1e-3)."""

    def body(v):
        if v < 50:
            return 1e-3, None  # within tolerance
        if noted is not None:
            note(ratio=noted)
        raise AssertionError("planted: the example is wrong")

    res = run_property(
        "planted.raises",
        "-",
        body,
        st.integers(0, 100),
        max_examples=40,
        seed=1,
        explicit=(3, 77),
        shrink_seconds=1.0,
    )
    assert not res.passed
    assert res.worst_ratio == (noted if noted is not None else math.inf)


def test_noted_numpy_scalars_render_as_plain_numbers():
    """A failing example's notes are paste-able Python: numpy 2's scalar repr
    (``np.float64(22.7)``) showed in certificates when a check noted a numpy ratio."""

    def body(v):
        note(ratio=np.float64(22.5), pair=(np.float64(0.25), "a"), steps=np.int64(7))
        raise AssertionError("planted")

    res = run_property(
        "planted.numpy", "-", body, st.integers(0, 3), max_examples=2, seed=0, shrink_seconds=1.0
    )
    text = res.falsifying_example
    assert not res.passed and "np." not in text, text
    assert "ratio = 22.5" in text and "pair = (0.25, 'a')" in text and "steps = 7" in text, text
