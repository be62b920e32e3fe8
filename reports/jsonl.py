"""Implementations in any language, spoken to over JSON lines (docs/design.md, certification).

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

Incidents, each raised as :class:`ProgramFailure` (never ``ValueError``, so a broken reply
can never pass as "refused a degenerate point") and recorded in
:attr:`CommandImplementation.incidents` with the tail of the program's stderr:

* **hang**: no reply with the request's id within ``timeout`` seconds (one deadline per
  request, however many other lines the program prints meanwhile; the first request after
  each start gets ``max(timeout, startup_timeout)``, so a slow start-up is not a hang);
* **crash**: the program exited (it is restarted);
* **garbage**: a line that is not a JSON object;
* **malformed**: a reply without ``result``/``error``, or a ``result`` that is not the
  method's shape of real numbers (``"abc"``, ``null``, a wrong shape). NaN and infinities
  are numbers: the checks judge them.

After ``max_failures`` incidents in a row without one good reply the program is declared
broken: every further request raises :class:`ProgramBroken` at once, which ends the check
without shrinking (so a program that never answers costs ``max_failures * timeout``
seconds, not one timeout per example). The program runs in its own process group
(inside the harness's session, :mod:`reports._supervise`); :meth:`CommandImplementation.close` kills the whole group (children a program
forked included) and reaps it. Its stderr goes to ``stderr_log`` (a file) when given.
"""

from __future__ import annotations

import collections
import contextlib
import json
import math
import os
import queue
import shlex
import signal
import subprocess
import threading
import time
from typing import Any

import numpy as np

from tstarg.properties.runner import CheckAborted
from tstarg.refimpl import PROTOCOL as SPEC

from .jsonl_schema import ProtocolError, sample_args, validate_reply, validate_request

__all__ = ["METHODS", "CommandImplementation", "ProgramBroken", "ProgramFailure"]

METHODS = {m.name: m.arg_names for m in SPEC.methods}
"""Method -> its argument names, from the protocol spec (refimpl/_protocol.py)."""
MAX_TIMEOUT = 3600.0
STDERR_TAIL = 15  # lines of the program's stderr quoted per incident


class ProgramFailure(RuntimeError):
    """The external program hung (no reply within the timeout), crashed, or replied garbage."""


class ProgramBroken(CheckAborted):
    """The program failed ``max_failures`` requests in a row: the check ends now (no shrinking)."""


def _plain(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return v


def check_timeout(timeout: Any, what: str = "timeout") -> float:
    """A per-request timeout: a finite number of seconds in (0, 3600]."""
    try:
        t = float(timeout)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number of seconds, got {timeout!r}") from None
    if not (math.isfinite(t) and 0 < t <= MAX_TIMEOUT):
        raise ValueError(f"{what} must be in (0, {MAX_TIMEOUT:g}] seconds, got {timeout!r}")
    return t


def _real_array(value: Any, what: str) -> np.ndarray:
    """Nested lists of real numbers (bool and strings refused) -> float array, else ProgramFailure."""

    def ok(v):
        if isinstance(v, list):
            return all(ok(x) for x in v)
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    if not ok(value):
        raise ProgramFailure(
            f"{what}: expected nested lists of numbers, got {json.dumps(value)[:200]}"
        )
    try:
        return np.asarray(value, dtype=float)
    except ValueError:  # ragged
        raise ProgramFailure(f"{what}: ragged nested lists {json.dumps(value)[:200]}") from None


def parse_result(method: str, result: Any, args: dict) -> Any:
    """Validate a reply's ``result`` against the method's shapes; returns arrays (or raises ProgramFailure)."""
    if method == "capabilities":
        if not isinstance(result, dict):
            raise ProgramFailure(
                f"capabilities result must be an object, got {json.dumps(result)[:200]}"
            )
        return result
    spec = SPEC.by_name[method]
    n = len(args["f"])
    lead = np.shape(args[spec.arg_names[spec.lead_index]])[:-1]
    shapes = spec.result_shapes(n, lead)
    if spec.result == "tensor":
        P = _real_array(result, f"{method} result")
        if P.shape != shapes[0]:
            raise ProgramFailure(f"{method} result has shape {P.shape}, expected {shapes[0]}")
        return P
    if not isinstance(result, list) or len(result) != len(shapes):
        raise ProgramFailure(
            f"{method} result must be a list [{', '.join(spec.parts)}] of {len(shapes)} vectors, "
            f"got {json.dumps(result)[:200]}"
        )
    parts = tuple(_real_array(r, f"{method} result[{k}]") for k, r in enumerate(result))
    if tuple(p.shape for p in parts) != shapes:
        raise ProgramFailure(
            f"{method} result has shapes {', '.join(str(p.shape) for p in parts)}, "
            f"expected {', '.join(map(str, shapes))}"
        )
    return parts


class CommandImplementation:
    """Wrap ``PROGRAM ARGS`` as an implementation object (``batched = False``)."""

    batched = False

    def __init__(
        self,
        command: str,
        *,
        timeout: float = 10.0,
        probe: bool = True,
        stderr_log: str | os.PathLike | None = None,
        max_failures: int = 3,
        startup_timeout: float = 30.0,
    ):
        self.command = command
        self.timeout = check_timeout(timeout)
        self.startup_timeout = max(self.timeout, check_timeout(startup_timeout, "startup timeout"))
        self._fresh = True
        self.name = f"cmd: {command}"
        self.version = "external"
        self.incidents: list[dict] = []
        self.max_failures = int(max_failures)
        self._failures_in_a_row = 0
        self._broken: str | None = None
        self._proc = None
        self._next_id = 0
        self._lines: queue.Queue = queue.Queue()
        self._missing: set[str] = set()
        self._expired: set[int] = set()  # ids of requests that timed out (late replies skipped)
        self._tail: collections.deque = collections.deque(maxlen=STDERR_TAIL)
        self._log = (
            open(stderr_log, "a", encoding="utf-8", errors="replace") if stderr_log else None
        )  # noqa: SIM115
        argv = shlex.split(command)
        if not argv:
            raise ValueError("--cmd: the program command is empty")
        self._argv = argv
        self._start()
        if probe:
            self._probe()

    # ------------------------------------------------------------ process
    def _start(self) -> None:
        try:
            self._proc = subprocess.Popen(
                self._argv,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                bufsize=1,
                errors="replace",
                process_group=0,  # its own group (killed whole), in the harness's session
            )
        except OSError as exc:
            raise ProgramFailure(
                f"cannot start the program {self._argv[0]!r}: {exc.strerror or exc}"
            ) from None
        self._fresh = True
        self._lines = queue.Queue(maxsize=10000)
        self._tail = collections.deque(maxlen=STDERR_TAIL)  # this run of the program only
        proc, lines, tail = self._proc, self._lines, self._tail

        def reader():
            with contextlib.suppress(ValueError, OSError):  # the pipe closed under us by close()
                for line in proc.stdout:
                    lines.put(line)
            lines.put(None)

        def err_reader():
            with contextlib.suppress(ValueError, OSError):
                for line in proc.stderr:
                    tail.append(line.rstrip("\n"))
                    if self._log is not None:
                        self._log.write(line)
                        self._log.flush()

        threading.Thread(target=reader, daemon=True).start()
        threading.Thread(target=err_reader, daemon=True).start()

    def _restart(self) -> None:
        self._kill()
        self._start()

    def _kill(self) -> None:
        proc = self._proc
        if proc is None:
            return
        with contextlib.suppress(ProcessLookupError, PermissionError, OSError):
            os.killpg(proc.pid, signal.SIGKILL)  # the program and every child it forked
        with contextlib.suppress(ProcessLookupError, OSError):
            proc.kill()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:  # pragma: no cover - SIGKILL is not ignorable
            pass
        for stream in (proc.stdin, proc.stdout, proc.stderr):
            with contextlib.suppress(OSError, ValueError):
                stream.close()

    def close(self) -> None:
        """Kill the program's process group and reap it; close the stderr log."""
        self._kill()
        self._proc = None
        if self._log is not None:
            time.sleep(0.05)  # let the stderr reader write what it has
            with contextlib.suppress(OSError):
                self._log.close()
            self._log = None

    def __del__(self):  # pragma: no cover
        with contextlib.suppress(Exception):
            self.close()

    # ------------------------------------------------------------ requests
    def _incident(self, rid: int, method: str, kind: str, detail: str, *, restart: bool) -> str:
        if restart:
            time.sleep(0.05)  # the last words of a crashing program reach the stderr reader
        tail = list(self._tail)
        self.incidents.append(
            {"id": rid, "method": method, "kind": kind, "detail": detail, "stderr_tail": tail}
        )
        self._failures_in_a_row += 1
        if self._failures_in_a_row >= self.max_failures:
            self._broken = (
                f"{self._failures_in_a_row} requests in a row failed (last: {kind}, {detail}); "
                "the program is not restarted again"
            )
            self._kill()
        elif restart:
            self._restart()
        msg = f"request {rid} ({method}): {kind}: {detail}"
        if tail:
            msg += " -- stderr tail: " + " | ".join(tail[-3:])
        return msg

    def request(self, method: str, args: dict) -> Any:
        if self._broken:
            raise ProgramBroken(f"the program is broken: {self._broken}")
        self._next_id += 1
        rid = self._next_id
        req = {"id": rid, "method": method, "args": _plain(args)}
        validate_request(req)  # the harness's own side of the schema (reports/schema/)
        line = json.dumps(req)
        try:
            self._proc.stdin.write(line + "\n")
            self._proc.stdin.flush()
        except (BrokenPipeError, OSError, ValueError):
            raise ProgramFailure(
                self._incident(
                    rid, method, "crash", "the program had exited (stdin closed)", restart=True
                )
            ) from None
        wait = self.startup_timeout if self._fresh else self.timeout
        self._fresh = False
        deadline = time.monotonic() + wait
        while True:
            left = deadline - time.monotonic()
            try:
                if left <= 0:
                    raise queue.Empty
                reply = self._lines.get(timeout=left)
            except queue.Empty:
                self._expired.add(rid)
                raise ProgramFailure(
                    self._incident(rid, method, "hang", f"no reply within {wait:g} s", restart=True)
                ) from None
            if reply is None:  # stdout closed: the program exited, or is about to (or never will)
                try:
                    code = self._proc.wait(timeout=min(2.0, max(left, 0.1)))
                except subprocess.TimeoutExpired:
                    code = "none (it closed its stdout and kept running)"
                raise ProgramFailure(
                    self._incident(
                        rid, method, "crash", f"the program exited with code {code}", restart=True
                    )
                )
            try:
                msg = json.loads(reply)
            except (json.JSONDecodeError, RecursionError):
                msg = None
            if not isinstance(msg, dict):
                raise ProgramFailure(
                    self._incident(
                        rid, method, "garbage", f"not a JSON object: {reply[:200]!r}", restart=False
                    )
                )
            got = msg.get("id")
            if got != rid or type(got) is not type(rid):
                if type(got) is int and got in self._expired:
                    continue  # a late reply to an earlier, timed-out request (the deadline runs on)
                raise ProgramFailure(
                    self._incident(
                        rid,
                        method,
                        "garbage",
                        f"reply id {got!r} answers no pending request (expected {rid!r})",
                        restart=True,
                    )
                )
            self._last_reply = msg
            try:
                try:
                    validate_reply(msg, method)
                except ProtocolError as exc:
                    raise ProgramFailure(f"reply breaks the protocol schema: {exc}") from None
                if "error" in msg:
                    err = str(msg["error"])
                    self._failures_in_a_row = 0
                    if err.startswith("unknown method"):
                        self._missing.add(method)
                        raise NotImplementedError(err)
                    if err.startswith("ValueError"):
                        raise ValueError(err)
                    raise ProgramFailure(f"request {rid} ({method}): error reply {err!r}")
                if "result" not in msg:
                    raise ProgramFailure(f"reply has neither 'result' nor 'error': {reply[:200]!r}")
                out = parse_result(method, msg["result"], args)
            except ProgramFailure as exc:
                if "error reply" in str(exc):
                    raise
                raise ProgramFailure(
                    self._incident(rid, method, "malformed", str(exc), restart=False)
                ) from None
            self._failures_in_a_row = 0
            return out

    def _probe(self) -> None:
        """Find which methods the program provides, with a small su(2) request each."""
        try:
            caps = self.request("capabilities", {})
        except (NotImplementedError, ValueError):
            caps = None
        except ProgramFailure as exc:
            caps = None
            if isinstance(getattr(self, "_last_reply", {}).get("result"), dict):
                self.capabilities_error = str(exc)  # a malformed declaration: refused, not ignored
        except ProgramBroken:
            return
        if isinstance(caps, dict):
            self._declare(caps)
        for method in METHODS:
            if method in self._missing:
                continue
            try:
                self.request(method, sample_args(method))
            except NotImplementedError:
                self._missing.add(method)
            except (ValueError, ProgramFailure):
                pass
            except ProgramBroken:
                return

    def _declare(self, caps: dict) -> None:
        """The ``capabilities`` reply (reports/schema/reply.schema.json) as the object's attributes:
        ``domain`` (the keys the certification reads), ``batched``, the promised accuracy, the name."""
        self.capabilities = caps
        self.name = str(caps.get("name", getattr(self, "name", "program")))
        self.version = str(caps.get("version", getattr(self, "version", "")))
        if "methods" in caps:
            self._missing |= set(METHODS) - set(caps["methods"])
        domain = {
            a.name: caps[a.name]
            for a in SPEC.attributes
            if a.where == "domain" and caps.get(a.name) is not None and caps[a.name] != "all"
        }
        if domain:
            self.domain = domain
        self.batched = bool(caps.get("batched", False))
        for a in SPEC.attributes:
            if a.where == "attribute" and a.name not in ("name", "version", "batched"):
                if a.name in caps:
                    setattr(self, a.name, caps[a.name])

    def __getattr__(self, method: str):
        if method in METHODS and method not in self.__dict__.get("_missing", set()):
            names = METHODS[method]

            def call(*args, **kw):
                if len(args) != len(names):
                    raise TypeError(
                        f"{method} takes {len(names)} arguments ({', '.join(names)}), got {len(args)}"
                    )
                optional = {a.name: a.kind for a in SPEC.by_name[method].optional}
                if set(kw) - set(optional):  # the spec's optional arguments (flow's steps)
                    raise TypeError(f"{method} got unexpected keyword arguments {sorted(kw)}")
                extra = {
                    k: int(v) if optional[k] == "integer" else v
                    for k, v in kw.items()
                    if v is not None
                }
                return self.request(method, {**dict(zip(names, args)), **extra})

            return call
        raise AttributeError(method)
