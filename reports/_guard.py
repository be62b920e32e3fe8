"""What ``tstarg certify`` puts between the battery and the implementation under test.

* :func:`materialize` turns a target description into an implementation: ``"module:object"``,
  a bare ``"module"`` (docs/design.md: an implementation may be a module), or
  ``{"cmd": "PROGRAM ARGS", "timeout": s, "stderr_log": path}`` for a JSON-lines program
  (:mod:`reports.jsonl`). A target that provides none of the protocol's methods is refused
  (:class:`NotAnImplementation`) before anything runs.
* :class:`Guarded` wraps it: every call has a time limit (``call_timeout``; after
  ``max_timeouts`` of them the check is aborted instead of shrunk), ``sys.exit`` inside a
  method ends the check as a failure (never the process), a method that mutates its inputs
  or returns something that is not the protocol's shape of real numbers fails with that
  reason, and each call is recorded (:func:`properties.runner.note`) so that a failing
  example shows what the implementation was asked and what it returned.
* :func:`explain` adds, for a failed reference check whose body recorded no expected value,
  the worst entry (expected from the reference at 30 digits, got, error, tolerance = error /
  ratio) to the rendered example.
* :func:`load` is the one target loader (guarded or bare); the run-and-merge that uses it is
  :func:`reports.certification.run.certify_target` (one unit per check id, in worker
  processes by default), each worker on its own guarded copy of the target, with the run's
  budgets (:mod:`properties.runner` limits), and merges the partial certificates in check order.
"""

from __future__ import annotations

import copy
import math
import time
from typing import Any

import numpy as np

from tstarg.properties import runner
from tstarg.properties.runner import CheckAborted, TimeLimitExceeded, note, time_limit
from tstarg.refimpl import PROTOCOL, check_attributes, provided_methods, provides

from ._imports import import_module, resolve
from .jsonl import METHODS, CommandImplementation, check_timeout

__all__ = [
    "Guarded",
    "NotAnImplementation",
    "close_target",
    "explain",
    "load",
    "materialize",
]

ATTRIBUTES = (
    tuple(a.name for a in PROTOCOL.attributes if a.where == "attribute")
    + (
        "domain",  # the declared domain (certification.declared_domain): hidden, it was never certified
        "group",  # the group the flows live on (certification.group): hidden, SO(3) would be judged as SU(2)
    )
)
"""The attributes the guard passes through, from the protocol spec."""


class NotAnImplementation(ValueError):
    """The target provides none of the protocol's methods, or declares an invalid attribute."""


def _validate_attributes(target, label: str) -> None:
    """The spec's types and caps (a declared tolerance past its cap is refused, never trusted)."""
    problems = check_attributes(target, f"target {label}")
    caps_error = getattr(target, "capabilities_error", None)
    if caps_error:
        problems.append(f"target {label}: its capabilities reply is refused: {caps_error}")
    if problems:
        raise NotAnImplementation("; ".join(problems))


WARMUP_FACTOR = 6.0
"""The first call of a method on a new model structure may take ``WARMUP_FACTOR`` times the per-call
timeout: implementations that compile on first use (numba, JAX, heyoka, ...) pay it there, once
per structure, and a hang is still bounded."""


def structure_key(method: str, args: tuple) -> tuple:
    """What a compiling implementation specialises on: the method, the dimension, which of Theta,
    Upsilon and the potential are present, and the batch rank of the point."""
    try:
        f, theta, upsilon = (np.asarray(a, dtype=float) for a in args[:3])
        point = args[3] if method == "poisson_tensor" else args[5]
        potential = None if method == "poisson_tensor" else args[4]
        return (
            method,
            f.shape,
            bool(np.any(theta)),
            bool(np.any(upsilon)),
            potential is None,
            np.ndim(point),
        )
    except Exception:  # noqa: BLE001 - a malformed call is judged elsewhere; key it by method
        return (method,)


class Guarded:
    """An implementation under test, with a time limit per call and checked inputs and outputs.

    The first call per :func:`structure_key` gets :data:`WARMUP_FACTOR` times the per-call timeout
    (compilation on first use); every later call gets the per-call timeout itself."""

    def __init__(
        self, target, *, call_timeout: float = 10.0, label: str = "", max_timeouts: int = 3
    ):
        self._target = target
        self._label = label or repr(target)
        self.call_timeout = float(call_timeout)
        if not (math.isfinite(self.call_timeout) and self.call_timeout > 0):
            raise ValueError(
                f"call timeout must be a positive number of seconds, got {call_timeout!r}"
            )
        self.max_timeouts = int(max_timeouts)
        self._timeouts = 0
        self._warm: set = set()  # structure keys already called once (compiled, if it compiles)
        self._own_incidents: list[dict] = []
        provided = provided_methods(target)
        if not provided:
            raise NotAnImplementation(
                f"target {self._label} ({type(target).__name__}) provides none of the protocol's methods "
                f"({', '.join(METHODS)}): not an implementation (docs/design.md, the implementation protocol)"
            )
        _validate_attributes(target, self._label)
        self.provided = provided

    @property
    def incidents(self) -> list:
        theirs = self._target.incidents if isinstance(self._target, CommandImplementation) else []
        return self._own_incidents + list(theirs)

    def _incident(self, method: str, kind: str, detail: str) -> None:
        """Record one of the guard's own incidents (numbered from 1 in the order they happen)."""
        self._own_incidents.append(
            {"id": len(self._own_incidents) + 1, "method": method, "kind": kind, "detail": detail}
        )

    def close(self) -> None:
        if isinstance(self._target, CommandImplementation):
            self._target.close()

    def __getattr__(self, attr: str):
        if attr.startswith("_"):
            raise AttributeError(attr)
        if attr in METHODS:
            if not provides(self._target, attr):  # the spec's test: a placeholder is not provided
                raise AttributeError(attr)
            fn = getattr(self._target, attr)
            return lambda *args, **kw: self._call(attr, fn, args, kw)
        if attr == "name":  # the certificate names the target, never this wrapper
            return getattr(self._target, "name", None) or self._label
        if attr in ATTRIBUTES:
            return getattr(self._target, attr)
        raise AttributeError(attr)

    def _call(self, method: str, fn, args: tuple, kw: dict):
        names = METHODS[method]
        if self._timeouts >= self.max_timeouts:
            raise CheckAborted(
                f"{method}: {self._timeouts} calls exceeded the per-call timeout of "
                f"{self.call_timeout:g} s; no further calls are made"
            )
        saved = [copy.deepcopy(a) for a in args]
        t0 = time.perf_counter()
        try:
            key = structure_key(method, args)
            limit = self.call_timeout * (1.0 if key in self._warm else WARMUP_FACTOR)
            self._warm.add(key)
            with time_limit(limit, "call"):
                out = fn(*args, **kw)
        except TimeLimitExceeded as exc:
            if exc.what == "example":  # the implementation itself used the example's whole budget
                raise AssertionError(
                    f"{method} was still running when the example's budget of {exc.seconds:g} s ran out"
                ) from None
            if exc.what != "call":
                raise
            self._timeouts += 1
            self._incident(method, "hang", f"no return within the per-call timeout of {limit:g} s")
            raise AssertionError(
                f"{method} did not return within the per-call timeout of {limit:g} s"
                + (
                    ""
                    if limit == self.call_timeout
                    else " (its first call on this model structure)"
                )
            ) from None
        except SystemExit as exc:
            self._incident(method, "exit", f"sys.exit({exc.code!r}) inside the method")
            raise CheckAborted(
                f"{method} called sys.exit({exc.code!r}): an implementation must return or raise, "
                "never end the process"
            ) from None
        finally:
            note(
                call={
                    "method": method,
                    "args": dict(zip(names, saved)),
                    "seconds": time.perf_counter() - t0,
                }
            )
            self._check_unchanged(method, names, saved, args)
        if len(args) != len(names):
            return out  # not the protocol's call shape: the target's own business
        res = _validate_result(method, out, args)
        note(
            call={
                "method": method,
                "args": dict(zip(names, saved)),
                "result": res,
                "seconds": time.perf_counter() - t0,
            }
        )
        return res

    @staticmethod
    def _check_unchanged(method, names, saved, args) -> None:
        for name, before, now in zip(names, saved, args):
            same = (
                np.array_equal(before, now, equal_nan=True)
                if isinstance(before, np.ndarray)
                else _same(before, now)
            )
            if not same:
                raise AssertionError(
                    f"{method} mutated its input {name!r} (an implementation never mutates its inputs)"
                )


def _same(a, b) -> bool:
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)
    return a == b or (
        isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b)
    )


def _real(value: Any, what: str) -> np.ndarray:
    try:
        arr = np.asarray(value)
    except Exception as exc:  # noqa: BLE001 - anything that is not an array of numbers
        raise AssertionError(f"{what}: not an array ({type(exc).__name__}: {exc})") from None
    if arr.dtype.kind not in "fiu" and not (
        arr.dtype == object
        and all(isinstance(v, (int, float)) or hasattr(v, "__float__") for v in arr.ravel())
    ):
        raise AssertionError(f"{what}: expected real numbers, got {arr.dtype} ({str(value)[:120]})")
    if arr.dtype.kind == "c":  # pragma: no cover - excluded above
        raise AssertionError(f"{what}: complex values")
    try:
        return arr.astype(float)
    except (TypeError, ValueError) as exc:
        raise AssertionError(f"{what}: not real numbers ({exc})") from None


def _validate_result(method: str, out: Any, args: tuple) -> Any:
    """The protocol's output shapes of real numbers (from the spec); anything else is a failure
    (never a ValueError)."""
    spec = PROTOCOL.by_name[method]
    f = np.asarray(args[0])
    n = f.shape[0] if f.ndim == 3 else 0
    lead = np.shape(args[spec.lead_index])[:-1]
    shapes = spec.result_shapes(n, lead)
    if spec.result == "tensor":
        P = _real(out, f"{method} result")
        if P.shape != shapes[0]:
            raise AssertionError(f"{method} returned shape {P.shape}, expected {shapes[0]}")
        return P
    if not isinstance(out, (tuple, list)) or len(out) != len(shapes):
        raise AssertionError(
            f"{method} must return a tuple ({', '.join(spec.parts)}) of {len(shapes)} arrays, "
            f"got {type(out).__name__}: {str(out)[:120]}"
        )
    parts = tuple(_real(v, f"{method} result[{k}]") for k, v in enumerate(out))
    if tuple(p.shape for p in parts) != shapes:
        raise AssertionError(
            f"{method} returned shapes {', '.join(str(p.shape) for p in parts)}, "
            f"expected {', '.join(map(str, shapes))}"
        )
    return parts


# ------------------------------------------------------------------ targets
def materialize(spec, *, call_timeout: float = 10.0):
    """A guarded implementation from ``"module:object"``, ``"module"`` or ``{"cmd": ..., ...}``."""
    if isinstance(spec, dict) and "cmd" in spec:
        timeout = check_timeout(spec.get("timeout", call_timeout), "--timeout")
        startup = check_timeout(spec.get("startup_timeout", 30.0), "--startup-timeout")
        impl = CommandImplementation(
            spec["cmd"], timeout=timeout, stderr_log=spec.get("stderr_log"), startup_timeout=startup
        )
        # the program's own timeout is per request; the guard's is a backstop above it
        try:
            return Guarded(
                impl, call_timeout=max(timeout, startup) * 2 + 5, label=f"--cmd {spec['cmd']!r}"
            )
        except NotAnImplementation:
            impl.close()
            raise
    if not isinstance(spec, str) or not spec:
        raise ValueError(
            f"certification target must be 'module', 'module:object' or {{'cmd': ...}}, got {spec!r}"
        )
    obj = resolve(spec) if ":" in spec else import_module(spec)
    return Guarded(obj, call_timeout=call_timeout, label=spec)


# ------------------------------------------------------------------ explaining a failure
def explain(check, *, seconds: float = 60.0) -> None:
    """Complete a failed reference check's example with the worst entry, from the recorded call.

    Only when the body recorded no ``expected``: the reference is evaluated once at the
    recorded inputs (30 digits; the flow at 25, under a ``seconds`` time limit).
    """
    ex = check.extra.get("example")
    if check.passed or not ex or "worst_entry" in ex or ".reference" not in check.name:
        return
    call = runner.decode(ex.get("notes", {}).get("call"))
    if not isinstance(call, dict) or "result" not in call:
        return
    from tstarg.refimpl.reference import Reference

    a, method = call["args"], call["method"]
    spec = PROTOCOL.by_name.get(method)
    if spec is None:
        return
    try:
        with time_limit(seconds, "explain"):
            ref = getattr(Reference(spec.reference_digits), method)
            exp = ref(*(a[k] for k in spec.arg_names))
            got = call["result"]
            if spec.result == "pair":
                exp, got = np.concatenate(exp), np.concatenate(got)
    except TimeLimitExceeded:
        ex["worst_entry_note"] = (
            f"the reference at the example took over {seconds:g} s: not recomputed"
        )
        return
    except Exception as exc:  # noqa: BLE001 - an explanation must not turn into a crash
        ex["worst_entry_note"] = f"reference not recomputed: {type(exc).__name__}: {exc}"
        return
    ratio = runner.decode(ex.get("ratio"))
    notes = {"expected": np.asarray(exp, dtype=float), "got": np.asarray(got, dtype=float)}
    worst = runner.worst_entry(notes, ratio if isinstance(ratio, float) else None)
    if worst is None:
        return
    ex["worst_entry"] = worst
    idx = ",".join(map(str, worst["index"]))
    name = spec.symbol
    line = (
        f"  worst entry {name}[{idx}] (reference recomputed at the recorded call): expected "
        f"{worst['expected']!r}, got {worst['got']!r}, error {worst['error']:.3e}"
        + (
            f", tolerance {worst['tolerance']:.3e} (error / ratio), ratio {worst['ratio']:.3g}"
            if "tolerance" in worst
            else ""
        )
    )
    check.falsifying_example = check.falsifying_example + "\n" + line


# ------------------------------------------------------------------ targets, one loader
def load(spec, *, guard: bool = True, call_timeout: float | None = 10.0):
    """The one target loader: ``"module"``, ``"module:object"``, ``{"cmd": ...}`` or an object
    (in-process runs); guarded (:func:`materialize`) unless ``guard`` is False."""
    if guard:
        if not isinstance(spec, (str, dict)):
            return Guarded(spec, call_timeout=call_timeout or 3600.0)
        return materialize(spec, call_timeout=call_timeout or 3600.0)
    if isinstance(spec, dict) and "cmd" in spec:
        return CommandImplementation(
            spec["cmd"],
            timeout=check_timeout(spec.get("timeout", call_timeout or 10.0), "--timeout"),
            stderr_log=spec.get("stderr_log"),
        )
    if isinstance(spec, str):
        if not spec:
            raise ValueError("certification target must not be empty")
        return resolve(spec) if ":" in spec else import_module(spec)
    return spec


def close_target(impl) -> None:
    close = getattr(impl, "close", None)
    if callable(close) and isinstance(impl, (Guarded, CommandImplementation)):
        close()
