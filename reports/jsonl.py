"""Implementations in any language, spoken to over JSON lines (DESIGN.md, certification).

The program reads one request per line on stdin and writes one reply per line on stdout:

    request: {"id": 7, "method": "poisson_tensor", "args": {"f": [...], "theta": [...], ...}}
    reply:   {"id": 7, "result": [[...], ...]}    or    {"id": 7, "error": "message"}

``args`` holds the protocol's parameters by name (``f, theta, upsilon, x, pi`` for
``poisson_tensor``; ``f, theta, upsilon, inertia, potential, x, pi`` for
``hamiltonian_vector_field``; ``f, theta, upsilon, inertia, potential, x0, pi0, t`` for
``flow``), arrays as nested lists. Results: ``P`` as nested lists; ``[xdot, pidot]``;
``[x, pi]``. An error reply whose message starts with ``ValueError`` is raised as
``ValueError`` (e.g. a degenerate point); a reply ``{"error": "unknown method ..."}`` to
the first request of a method marks that method as not provided (skipped).

A request that gets no reply within ``timeout`` seconds is a **hang**; a program that
exits is a **crash**. Either is raised as :class:`ProgramFailure` (not ``ValueError``),
recorded in :attr:`CommandImplementation.incidents`, and the program is restarted, so one
bad request never stops the harness.
"""

from __future__ import annotations

import json
import queue
import shlex
import subprocess
import threading
from typing import Any

import numpy as np

__all__ = ["CommandImplementation", "ProgramFailure"]

METHODS = {
    "poisson_tensor": ("f", "theta", "upsilon", "x", "pi"),
    "hamiltonian_vector_field": ("f", "theta", "upsilon", "inertia", "potential", "x", "pi"),
    "flow": ("f", "theta", "upsilon", "inertia", "potential", "x0", "pi0", "t"),
}


class ProgramFailure(RuntimeError):
    """The external program hung (no reply within the timeout) or crashed."""


def _plain(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return v


class CommandImplementation:
    """Wrap ``PROGRAM ARGS`` as an implementation object (``batched = False``)."""

    batched = False

    def __init__(self, command: str, *, timeout: float = 10.0, probe: bool = True):
        self.command = command
        self.timeout = float(timeout)
        self.name = f"cmd: {command}"
        self.version = "external"
        self.incidents: list[dict] = []
        self._proc = None
        self._next_id = 0
        self._lines: queue.Queue = queue.Queue()
        self._missing: set[str] = set()
        self._start()
        if probe:
            self._probe()

    # ------------------------------------------------------------ process
    def _start(self) -> None:
        self._proc = subprocess.Popen(shlex.split(self.command), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                      stderr=subprocess.DEVNULL, text=True, bufsize=1)
        self._lines = queue.Queue()
        proc, lines = self._proc, self._lines

        def reader():
            for line in proc.stdout:
                lines.put(line)
            lines.put(None)

        threading.Thread(target=reader, daemon=True).start()

    def _restart(self) -> None:
        self.close()
        self._start()

    def close(self) -> None:
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
            try:
                self._proc.wait(timeout=5)
            except subprocess.TimeoutExpired:  # pragma: no cover
                pass

    def __del__(self):  # pragma: no cover
        try:
            self.close()
        except Exception:
            pass

    # ------------------------------------------------------------ requests
    def request(self, method: str, args: dict) -> Any:
        self._next_id += 1
        rid = self._next_id
        line = json.dumps({"id": rid, "method": method, "args": _plain(args)})
        try:
            self._proc.stdin.write(line + "\n")
            self._proc.stdin.flush()
        except (BrokenPipeError, OSError):
            self.incidents.append({"id": rid, "method": method, "kind": "crash", "detail": "stdin closed"})
            self._restart()
            raise ProgramFailure(f"request {rid} ({method}): the program had exited (crash)") from None
        while True:
            try:
                reply = self._lines.get(timeout=self.timeout)
            except queue.Empty:
                self.incidents.append({"id": rid, "method": method, "kind": "hang",
                                       "detail": f"no reply within {self.timeout} s"})
                self._restart()
                raise ProgramFailure(f"request {rid} ({method}): no reply within {self.timeout} s (hang)") from None
            if reply is None:
                code = self._proc.wait()
                self.incidents.append({"id": rid, "method": method, "kind": "crash", "detail": f"exit code {code}"})
                self._restart()
                raise ProgramFailure(f"request {rid} ({method}): the program exited with code {code} (crash)")
            try:
                msg = json.loads(reply)
            except json.JSONDecodeError:
                self.incidents.append({"id": rid, "method": method, "kind": "garbage", "detail": reply[:200]})
                raise ProgramFailure(f"request {rid} ({method}): unparseable reply {reply[:200]!r}") from None
            if msg.get("id") != rid:
                continue  # a late reply to an earlier, timed-out request
            if "error" in msg:
                err = str(msg["error"])
                if err.startswith("unknown method"):
                    self._missing.add(method)
                    raise NotImplementedError(err)
                if err.startswith("ValueError"):
                    raise ValueError(err)
                raise ProgramFailure(f"request {rid} ({method}): error reply {err!r}")
            return msg.get("result")

    def _probe(self) -> None:
        """Find which methods the program provides, with a small su(2) request each."""
        eps = [[[0, 0, 0], [0, 0, 1], [0, -1, 0]], [[0, 0, -1], [0, 0, 0], [1, 0, 0]], [[0, 1, 0], [-1, 0, 0], [0, 0, 0]]]
        z = [[0.0] * 3 for _ in range(3)]
        base = {"f": eps, "theta": z, "upsilon": z, "inertia": np.eye(3).tolist(), "potential": None,
                "x": [0.1, 0.2, 0.3], "pi": [1.0, 0.5, -0.2], "x0": [0.1, 0.2, 0.3], "pi0": [1.0, 0.5, -0.2], "t": 0.1}
        for method, names in METHODS.items():
            try:
                self.request(method, {k: base[k] for k in names})
            except NotImplementedError:
                self._missing.add(method)
            except (ValueError, ProgramFailure):
                pass

    def __getattr__(self, method: str):
        if method in METHODS and method not in self.__dict__.get("_missing", set()):
            names = METHODS[method]

            def call(*args):
                res = self.request(method, dict(zip(names, args)))
                if method == "poisson_tensor":
                    return np.asarray(res, dtype=float)
                return tuple(np.asarray(r, dtype=float) for r in res)

            return call
        raise AttributeError(method)
