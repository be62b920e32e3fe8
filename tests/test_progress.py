"""The shared progress display (reports/_progress.py): plain timestamped lines off a terminal,
a live rich display on one, nothing with quiet, a heartbeat in long steps, parallel results
shown in the parent as they arrive."""

from __future__ import annotations

import io
import re
import time

import pytest

from tstarg.reports._parallel import map_tasks
from tstarg.reports._progress import Progress

STAMP = re.compile(r"^\[\d\d:\d\d:\d\d \+\d+\.\ds\] ")


class _Tty(io.StringIO):
    def isatty(self):
        return True


def test_plain_lines_are_timestamped_and_count_done_and_left():
    out = io.StringIO()
    with Progress("demo", total=2, stream=out, heartbeat=60) as p:
        p.note("header")
        p.start("first", total=3)
        p.update(2)
        p.done("first", "PASS")
        p.start("second")
        p.done("second", "FAIL")
        p.phase("writing the report")
    lines = out.getvalue().splitlines()
    assert lines and all(STAMP.match(line) for line in lines), lines
    body = [STAMP.sub("", line) for line in lines]
    assert body == [
        "header",
        "demo [1/2] first running ...",
        "demo [1/2] first: PASS",
        "demo [2/2] second running ...",
        "demo [2/2] second: FAIL",
        "demo: writing the report ...",
    ]


def test_quiet_prints_nothing_even_on_a_terminal():
    out = _Tty()
    with Progress("demo", total=1, stream=out, quiet=True) as p:
        p.note("header")
        p.start("a", total=2)
        p.done("a", "PASS")
    assert out.getvalue() == ""


def test_heartbeat_breaks_a_long_silence_with_the_step_and_its_count():
    out = io.StringIO()
    with Progress("demo", total=1, stream=out, heartbeat=0.2) as p:
        p.start("slow", total=10)
        p.update(4)
        time.sleep(0.7)
        p.done("slow", "PASS")
    body = [STAMP.sub("", line) for line in out.getvalue().splitlines()]
    beats = [b for b in body if "still running" in b]
    assert beats, body
    assert all(b.startswith("demo [1/1] slow  4/10 ex (still running, ") for b in beats), beats


def test_terminal_display_shows_title_count_step_and_clock():
    out = _Tty()
    with Progress("demo", total=3, stream=out) as p:
        p.start("alpha", total=5)
        p.update(2)
        time.sleep(0.25)  # at least one refresh of the live display (10 per second)
        p.done("alpha", "PASS 0.1 s")
    text = re.sub(r"\x1b\[[0-9;?]*[a-zA-Z]", "", out.getvalue())
    assert "demo [1/3] alpha: PASS 0.1 s" in text  # the kept line
    assert re.search(r"0:00:0\d demo .* 0/3 alpha  2/5 ex", text), text[-400:]
    assert re.search(r"1/3", text)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="total"):
        Progress("x", total=-1)
    with pytest.raises(ValueError, match="mode"):
        Progress("x", mode="fancy")
    with pytest.raises(ValueError, match="heartbeat"):
        Progress("x", heartbeat=0)


def _square(x):
    time.sleep(0.05 * (3 - x))  # later items finish first
    return x * x


def _progress_in_worker(_):
    out = io.StringIO()
    with Progress("inner", total=1, stream=out) as p:
        p.done("step", "PASS")
    return out.getvalue()


@pytest.mark.parametrize("workers", [1, 2])
def test_parallel_results_are_reported_in_the_parent_as_they_arrive(workers):
    out = io.StringIO()
    with Progress("sweep", total=3, stream=out, heartbeat=60) as p:
        got = map_tasks(
            _square,
            [0, 1, 2],
            workers=workers,
            on_result=p.callback(lambda i, v: f"item {i}", lambda i, v: f"= {v}"),
        )
    assert got == [0, 1, 4]  # input order, whatever the arrival order
    body = [STAMP.sub("", line) for line in out.getvalue().splitlines()]
    assert sorted(b.split("] ", 1)[1] for b in body) == [
        "item 0: = 0",
        "item 1: = 1",
        "item 2: = 4",
    ]
    counters = sorted(b.split("] ", 1)[0] for b in body)
    assert counters == ["sweep [1/3", "sweep [2/3", "sweep [3/3"]


def test_a_display_inside_a_worker_process_is_quiet():
    assert map_tasks(_progress_in_worker, [0, 1], workers=2) == ["", ""]
