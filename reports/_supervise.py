"""The harness owns time, signals and exit codes: code under test runs in a supervised child.

:func:`run_supervised` runs ``FUNCTION(job)`` (a ``"module:function"`` name and a picklable
``job``) in a fresh Python process that leads its own session, and returns what the function
returned, or a :class:`Died` saying why there is nothing:

* the child gets a **hard wall** (``wall`` seconds): past it, every process of its session is
  killed (``SIGKILL``: the child, its worker processes, the JSON-lines programs it started,
  whatever they forked, threads and all), so a run ends on time whatever the target does
  (sleeps at import, blocks or cancels ``SIGALRM``, ignores ``SIGTERM``, starts a non-daemon
  thread, never replies);
* the child hands back its result through a file written atomically, then leaves with
  ``os._exit``: a hostile ``atexit`` handler or a non-daemon thread cannot change the outcome;
  whatever is left of its session afterwards is killed;
* a child that ends without a result (``os._exit(0)``, ``sys.exit`` at import, a
  ``KeyboardInterrupt``, a self-sent ``SIGKILL``) is reported as :class:`Died` with its exit
  code or signal, never as success;
* ``SIGINT``/``SIGTERM`` sent to the harness itself kill the child's session before the
  harness leaves.

The child imports modules from the current folder first, as ``python -m`` does.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import pickle
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ._atomic import write_bytes

__all__ = ["Died", "kill_session", "run_supervised", "session_members"]

CHILD_CODE = "from tstarg.reports._supervise import _child_main; _child_main()"


@dataclass
class Died:
    """The supervised child ended without a result: ``reason`` says how."""

    reason: str
    returncode: int | None = None
    timed_out: bool = False


def session_members(sid: int) -> list[int]:
    """Pids of the live processes whose session id is ``sid`` (Linux ``/proc``)."""
    out = []
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            stat = Path(entry.path, "stat").read_text()
        except OSError:
            continue
        # pid (comm) state ppid pgrp session ...: comm may hold spaces and parentheses
        fields = stat[stat.rfind(")") + 2 :].split()
        if len(fields) > 3 and int(fields[3]) == sid and fields[0] != "Z":
            out.append(int(entry.name))
    return out


def kill_session(sid: int, *, rounds: int = 50) -> None:
    """SIGKILL every process of session ``sid`` (repeated: a process may fork while dying)."""
    for _ in range(rounds):
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(sid, signal.SIGKILL)
        pids = session_members(sid) if Path("/proc").is_dir() else []
        if not pids:
            return
        for pid in pids:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(pid, signal.SIGKILL)
        time.sleep(0.02)


class _Interrupted(BaseException):
    def __init__(self, signum: int):
        self.signum = signum


def run_supervised(
    function: str, job: Any, *, wall: float, linger: float = 5.0, env: dict | None = None
) -> Any:
    """``function(job)`` in a supervised child within ``wall`` seconds: its return value, or
    :class:`Died`. ``linger``: how long a child that has handed back its result may take to leave
    before its session is killed."""
    with tempfile.TemporaryDirectory(prefix="tstarg-supervise-") as tmp:
        job_file, result_file = Path(tmp, "job.pickle"), Path(tmp, "result.pickle")
        job_file.write_bytes(pickle.dumps((function, job, os.getcwd())))
        proc = subprocess.Popen(
            [sys.executable, "-c", CHILD_CODE, str(job_file), str(result_file)],
            start_new_session=True,
            env=env,
        )
        handlers = {}

        def on_signal(signum, _frame):
            raise _Interrupted(signum)

        for sig in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(ValueError):  # not the main thread: no handler
                handlers[sig] = signal.signal(sig, on_signal)
        deadline = time.monotonic() + wall
        timed_out = False
        try:
            while True:
                try:
                    proc.wait(timeout=0.1)
                    break
                except subprocess.TimeoutExpired:
                    pass
                if result_file.exists():  # handed back: it has `linger` seconds to leave
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        proc.wait(timeout=linger)
                    break
                if time.monotonic() > deadline:
                    timed_out = True
                    break
        except _Interrupted as exc:
            kill_session(proc.pid)
            proc.wait()
            raise SystemExit(128 + exc.signum) from None
        finally:
            for sig, h in handlers.items():
                signal.signal(sig, h)
            kill_session(proc.pid)  # the child, its workers, its programs, their children
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=5)
        if result_file.exists():
            try:
                return pickle.loads(result_file.read_bytes())
            except Exception as exc:  # noqa: BLE001 - a torn or foreign result is no result
                return Died(f"its result could not be read ({type(exc).__name__}: {exc})")
        if timed_out:
            return Died(
                f"the run exceeded its hard wall of {wall:g} s and was killed "
                "(with every process it started)",
                proc.returncode,
                timed_out=True,
            )
        code = proc.returncode
        how = (
            f"was killed by signal {signal.Signals(-code).name}"
            if code is not None and code < 0
            else f"exited with code {code}"
        )
        return Died(
            f"the process running the target {how} before handing back a result "
            "(a target that ends the process, at import or in a method, cannot be certified)",
            code,
        )


def _child_main() -> None:
    """The child: run the job, hand back the result atomically, leave at once (``os._exit``)."""
    job_file, result_file = sys.argv[1], sys.argv[2]
    function, job, cwd = pickle.loads(Path(job_file).read_bytes())
    if cwd not in sys.path:
        sys.path.insert(0, cwd)  # modules in the current folder first, as `python -m` does
    mod_name, fn_name = function.split(":")
    fn = getattr(importlib.import_module(mod_name), fn_name)
    try:
        result = fn(job)
    except BaseException as exc:  # noqa: BLE001 - KeyboardInterrupt, SystemExit from a target
        result = Died(
            f"the run raised {type(exc).__name__}: {str(exc)[:500]} (from the target or the harness)"
        )
    data = pickle.dumps(result)
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    write_bytes(result_file, data)
    os._exit(0)
