"""The check runner's state is explicit (properties.runner.RunState): the budgets, the examples to
replay and the progress listeners hold for the extent of a ``with`` block and are restored when it
ends, also when it ends by an exception; nothing else changes them."""

from __future__ import annotations

import pytest
from hypothesis import strategies as st

from tstarg.properties import runner


def _check(name: str):
    """A check over the integers 0..9 whose body passes when the drawn value is below 10."""
    return runner.run_property(
        name, "-", lambda v: (v / 10, None), st.integers(0, 9), max_examples=3, seed=0
    )


def test_listeners_hear_exactly_the_checks_of_their_block():
    heard: list[tuple[str, str]] = []
    outer_heard: list[str] = []

    def listener(event, name, done, total, result=None):
        heard.append((event, name))

    def outer(event, name, done, total, result=None):
        outer_heard.append(name)

    _check("before")
    with runner.listening(outer):
        with runner.listening(listener):
            _check("inside")
            with runner.silenced():
                _check("muted")
        _check("outer only")
    _check("after")
    assert {n for _, n in heard} == {"inside"}
    assert ("start", "inside") in heard and ("done", "inside") in heard
    assert set(outer_heard) == {"inside", "outer only"}
    assert runner.current().listeners == ()


def test_state_is_restored_after_an_exception():
    before = runner.current()
    with pytest.raises(RuntimeError, match="boom"):
        with runner.limits(example_seconds=1.0, check_seconds=2.0):
            with runner.replaying({"x": 1}):
                assert runner.current().limits.check_seconds == 2.0
                assert dict(runner.current().replay) == {"x": 1}
                raise RuntimeError("boom")
    assert runner.current() == before


def test_replay_runs_the_named_check_on_its_example_only():
    """A replayed check sees exactly the stored example (here 7, ratio 0.7); another check is
    left out, marked ``not_replayed``; the caller's dict is copied, not kept."""
    examples = {"named": 7}
    with runner.replaying(examples):
        examples["named"] = 100  # a later change by the caller does not leak in
        named, other = _check("named"), _check("other")
    assert named.extra.get("replayed") and named.examples == 1
    assert named.worst_ratio == 7 / 10  # the body computes the same one division: exact equality
    assert other.extra.get("not_replayed") and other.examples == 0


def test_the_state_cannot_be_assigned():
    with pytest.raises(AttributeError):
        runner.current().limits.example_seconds = 1.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        runner.current().replay["x"] = 1  # type: ignore[index]
