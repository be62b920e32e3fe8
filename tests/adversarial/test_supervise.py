"""The supervisor (reports/_supervise.py): a result comes back whatever the child does after
handing it back; a child that hangs is killed at the wall with every process of its session,
grandchildren in their own process group included; a child that ends the process without a
result is reported, never taken for success."""

from __future__ import annotations

import os
import time

from tstarg.reports._supervise import Died, run_supervised


def _alive(pid: int) -> bool:
    try:
        state = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def test_result_survives_threads_and_atexit():
    t0 = time.monotonic()
    out = run_supervised("tests.adversarial.hostile:job_returns", [1, 2], wall=60)
    assert out == {"echo": [1, 2]}
    assert time.monotonic() - t0 < 50  # did not wait for the non-daemon thread


def test_hard_wall_kills_the_whole_session(tmp_path):
    pid_file = tmp_path / "pid"
    t0 = time.monotonic()
    out = run_supervised(
        "tests.adversarial.hostile:job_hangs_with_grandchild", str(pid_file), wall=8
    )
    assert isinstance(out, Died) and out.timed_out and "hard wall of 8 s" in out.reason
    assert time.monotonic() - t0 < 30
    grandchild = int(pid_file.read_text())
    time.sleep(0.2)
    assert not _alive(grandchild)


def test_exit_without_result_is_reported():
    out = run_supervised("tests.adversarial.hostile:job_exits", None, wall=60)
    assert isinstance(out, Died) and not out.timed_out and "exited with code 0" in out.reason
    assert os.getpid()  # the harness itself is still here
