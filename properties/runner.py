"""The check runner: property checks usable outside pytest, each returning a :class:`CheckResult`.

A check is a function of one drawn example that returns ``(ratio, digits)``:
``ratio`` is the worst error / tolerance (a pass needs ``ratio <= 1``) and
``digits`` the correct significant digits where that is meaningful. The
runner :func:`run_property` drives it with Hypothesis (shrinking a failure to
a minimal example) and records the number of examples, the worst ratio and
the falsifying example. properties, oracles and reports all use this one runner.

**A failed check shows its input.** The runner keeps the drawn values of the last failing
call (after shrinking: the minimal example) and renders them itself -- algebra name and
structure constants, Theta, Upsilon, the point, t, and whatever the body or the
implementation guard recorded with :func:`note` (the worst entry: expected vs got, error,
tolerance, ratio) -- in ``falsifying_example`` (text) and ``extra["example"]`` (data, exact
floats: enough to replay the example, see :func:`replaying`). Nothing of Hypothesis' own report
is pasted there (its wording changes between releases: 6.170 attaches the example as an
exception note, and its shrink-time-limit warning is not an example); that text is kept,
marked as such, in ``extra["hypothesis_output"]``.

**Every check has a cost budget that does not depend on luck** (:class:`Limits`):

* ``example_seconds``: one example (reference computation included) that runs longer is
  interrupted, not judged, and drawn again; the check counts these in
  ``extra["over_budget"]``. A check whose every example ran over its budget fails
  (nothing was verified).
* ``check_seconds``: when a check has used its budget it stops drawing (``extra
  ["stopped_at_budget"]``); a failure found before that is still reported, with the
  smallest failing example shrinking reached.
* ``shrink_seconds``: shrinking a failure stops this long after the first failing example
  (the verdict is known; a smaller example is a convenience).

Interruption uses ``SIGALRM`` (:func:`time_limit`), so it applies in the main thread of a
process on POSIX; elsewhere only the between-examples budget applies.

**The runner's state is explicit.** What a run of checks shares -- the budgets, the examples to
replay, the progress listeners -- is one immutable :class:`RunState`, held in a
:class:`contextvars.ContextVar` and changed only for the extent of a ``with`` block:
:func:`limits`, :func:`replaying`, :func:`listening` and :func:`silenced`; :func:`current` reads
it. Nothing outside this module assigns to it, and leaving a block restores what was there
(also on an exception). The one process-wide piece is the ``SIGALRM`` timer of
:func:`time_limit` (a process has one), kept private here.
"""

from __future__ import annotations

import contextlib
import contextvars
import io
import math
import re
import signal
import struct
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping
from dataclasses import asdict, dataclass, field, replace
from types import MappingProxyType
from typing import Any

import mpmath
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import example as hyp_example
from hypothesis import seed as hyp_seed
from hypothesis import strategies as st
from hypothesis.errors import Unsatisfiable, UnsatisfiedAssumption
from hypothesis.reporting import with_reporter

__all__ = [
    "CheckAborted",
    "CheckResult",
    "Limits",
    "RunState",
    "TimeLimitExceeded",
    "advance",
    "announce",
    "current",
    "decode",
    "encode",
    "finished",
    "limits",
    "listening",
    "replaying",
    "silenced",
    "note",
    "render_example",
    "run_property",
    "time_limit",
    "worst_entry",
]


@dataclass
class CheckResult:
    """The verdict of one check: examples run, worst error/tolerance ratio, digits, and why it failed."""

    name: str
    equations: str
    examples: int = 0
    worst_ratio: float = 0.0
    min_digits: float | None = None
    passed: bool = True
    skipped: int = 0
    detail: str = ""
    falsifying_example: str = ""
    seconds: float = 0.0
    extra: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        d = asdict(self)
        for k in ("worst_ratio", "min_digits"):
            v = d[k]
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = str(v)
        return d


# ------------------------------------------------------------------ time limits
class TimeLimitExceeded(BaseException):
    """A :func:`time_limit` block ran past its limit. A ``BaseException`` so that no
    ``except Exception`` in a check body or an implementation swallows it."""

    def __init__(self, what: str, seconds: float):
        super().__init__(f"{what} exceeded its time limit of {seconds:g} s")
        self.what, self.seconds = what, seconds


class CheckAborted(BaseException):
    """Raised (by a body or an implementation guard) to end a check at once, without
    shrinking: e.g. the program under test is broken beyond single incidents. The check
    fails with this message and the example it was raised on."""


_STACK: list[list] = []  # [deadline (monotonic), what, seconds]
_OLD_HANDLER: list = []


def _can_alarm() -> bool:
    return hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()


def _arm() -> None:
    if _STACK:
        left = min(e[0] for e in _STACK) - time.monotonic()
        signal.setitimer(signal.ITIMER_REAL, max(left, 1e-4))
    else:
        signal.setitimer(signal.ITIMER_REAL, 0)


def _on_alarm(signum, frame) -> None:
    now = time.monotonic()
    due = [e for e in _STACK if e[0] <= now + 1e-3]
    if not due:
        _arm()
        return
    entry = min(due, key=lambda e: e[0])
    _STACK.remove(entry)
    _arm()
    raise TimeLimitExceeded(entry[1], entry[2])


@contextlib.contextmanager
def time_limit(seconds: float | None, what: str):
    """Raise :class:`TimeLimitExceeded` (``.what == what``) in this block after ``seconds``.

    Nestable; ``None`` means no limit. Uses ``SIGALRM``: in a non-main thread or without
    ``setitimer`` the block runs unlimited. Pure-C loops that never return to Python are
    interrupted only when they do.
    """
    if seconds is None or not _can_alarm():
        yield
        return
    if not seconds > 0:
        raise ValueError(f"time limit for {what} must be positive, got {seconds!r}")
    if not _STACK:
        _OLD_HANDLER.append(signal.signal(signal.SIGALRM, _on_alarm))
    entry = [time.monotonic() + seconds, what, seconds]
    _STACK.append(entry)
    _arm()
    try:
        yield
    finally:
        if entry in _STACK:
            _STACK.remove(entry)
        _arm()
        if not _STACK and _OLD_HANDLER:
            signal.signal(signal.SIGALRM, _OLD_HANDLER.pop())


@dataclass(frozen=True)
class Limits:
    """Time budgets of :func:`run_property` (seconds; ``None``: unlimited)."""

    example_seconds: float | None = None
    check_seconds: float | None = None
    shrink_seconds: float | None = None
    deadline: float | None = None  # time.time() after which no check draws another example


@dataclass(frozen=True)
class RunState:
    """What the checks of one run share (see the module docstring): ``limits``, the budgets used
    when :func:`run_property` is not given its own; ``replay``, check name -> drawn example
    (decoded) -- while non-empty, :func:`run_property` runs a named check on exactly that example
    (no search, no shrinking) and leaves other checks out (``extra["not_replayed"]``); and
    ``listeners``, the progress listeners, callables ``(event, name, done, total, result=None)``
    with ``event`` in ``"start"``, ``"example"``, ``"done"``.

    >>> current() == RunState()  # outside any block: no budget, nothing to replay, no listener
    True
    >>> with limits(check_seconds=5.0):
    ...     current().limits.check_seconds
    5.0
    >>> current().limits.check_seconds is None  # restored when the block ends
    True
    """

    limits: Limits = Limits()
    replay: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    listeners: tuple[Callable[..., Any], ...] = ()


_STATE: contextvars.ContextVar[RunState] = contextvars.ContextVar(
    "tstarg_run_state", default=RunState()
)


def current() -> RunState:
    """The state the checks run under now."""
    return _STATE.get()


@contextlib.contextmanager
def _entered(state: RunState) -> Iterator[RunState]:
    token = _STATE.set(state)
    try:
        yield state
    finally:
        _STATE.reset(token)


@contextlib.contextmanager
def limits(
    example_seconds: float | None = None,
    check_seconds: float | None = None,
    shrink_seconds: float | None = None,
    run_seconds: float | None = None,
) -> Iterator[Limits]:
    """Run the enclosed checks with these budgets (``tstarg verify`` / ``certify`` set them per profile);
    ``run_seconds``: a budget for everything inside the block (checks started after it is used
    up stop at once and report that nothing was verified). Yields the budgets in force.

    >>> with limits(example_seconds=0):
    ...     pass
    Traceback (most recent call last):
    ...
    ValueError: example_seconds must be a positive number of seconds, got 0
    """
    new: dict[str, float | None] = {
        "example_seconds": example_seconds,
        "check_seconds": check_seconds,
        "shrink_seconds": shrink_seconds,
    }
    if run_seconds is not None:  # otherwise an enclosing run's deadline stays
        new["deadline"] = run_seconds
    for what, v in new.items():
        if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{what} must be a positive number of seconds, got {v!r}")
    if run_seconds is not None:
        new["deadline"] = time.time() + run_seconds
    state = current()
    with _entered(replace(state, limits=replace(state.limits, **new))) as entered:
        yield entered.limits


@contextlib.contextmanager
def replaying(examples: Mapping[str, Any]) -> Iterator[RunState]:
    """Run the enclosed checks on exactly these examples (check name -> decoded drawn example;
    :attr:`RunState.replay`): ``tstarg certify ... --replay certificate.json``."""
    frozen = MappingProxyType(dict(examples))
    with _entered(replace(current(), replay=frozen)) as state:
        yield state


@contextlib.contextmanager
def listening(*listeners: Callable[..., Any]) -> Iterator[RunState]:
    """Also tell these progress listeners about the enclosed checks (``tstarg verify`` registers
    its progress display)."""
    state = current()
    with _entered(replace(state, listeners=state.listeners + listeners)) as entered:
        yield entered


@contextlib.contextmanager
def silenced() -> Iterator[RunState]:
    """No progress listener for the enclosed checks (the mutants' checks fail by design: they stay
    out of any display)."""
    with _entered(replace(current(), listeners=())) as state:
        yield state


# ------------------------------------------------------------------ what a failing example was
_NOTES: contextvars.ContextVar[dict | None] = contextvars.ContextVar("tstarg_notes", default=None)
"""The notes of the example being run (None outside a check)."""


def note(**data) -> None:
    """Record facts about the example being run (``expected=``, ``got=``, ``tolerance=``,
    ``error=``, ``call=`` ...); shown with the example if it fails. No-op outside a check."""
    notes = _NOTES.get()
    if notes is not None:
        notes.update(data)


def encode(v: Any) -> Any:
    """A JSON-able form of a drawn value that :func:`decode` turns back into it (floats exact)."""
    if isinstance(v, np.ndarray):
        if v.dtype == object:
            return {"object_array": [encode(x) for x in v.ravel().tolist()], "shape": list(v.shape)}
        return {"array": encode(v.tolist()), "dtype": str(v.dtype)}
    if isinstance(v, (np.floating, float)):
        v = float(v)
        if math.isnan(v):  # a NaN's sign and payload bits are kept too (Hypothesis draws them)
            return {"float": "nan", "bits": struct.pack("<d", v).hex()}
        return v if math.isfinite(v) else {"float": repr(v)}
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.bool_,)):
        return bool(v)
    if isinstance(v, tuple):
        return {"tuple": [encode(x) for x in v]}
    if isinstance(v, list):
        return [encode(x) for x in v]
    if isinstance(v, dict):
        return {"dict": [[encode(k), encode(x)] for k, x in v.items()]}
    if v is None or isinstance(v, (bool, int, str)):
        return v
    if isinstance(v, mpmath.mpf):
        return {"mpf": mpmath.nstr(v, 40)}
    if isinstance(v, complex):
        return {"complex": [encode(v.real), encode(v.imag)]}
    return {"repr": repr(v)}


def decode(v: Any) -> Any:
    """Inverse of :func:`encode`."""
    if isinstance(v, list):
        return [decode(x) for x in v]
    if not isinstance(v, dict):
        return v
    if "array" in v:
        return np.array(decode(v["array"]), dtype=v.get("dtype", "float64"))
    if "object_array" in v:
        return np.array([decode(x) for x in v["object_array"]], dtype=object).reshape(v["shape"])
    if "float" in v:
        if "bits" in v:
            return struct.unpack("<d", bytes.fromhex(v["bits"]))[0]
        return float(v["float"])
    if "tuple" in v:
        return tuple(decode(x) for x in v["tuple"])
    if "dict" in v:
        return {decode(k): decode(x) for k, x in v["dict"]}
    if "mpf" in v:
        return mpmath.mpf(v["mpf"])
    if "complex" in v:
        return complex(decode(v["complex"][0]), decode(v["complex"][1]))
    if "repr" in v:
        raise ValueError(
            f"this example value cannot be replayed (only its repr was kept): {v['repr']!r}"
        )
    return v


def _fmt(a: Any) -> str:
    """One line; floats as their shortest round-trip repr (paste-able, exact)."""
    if isinstance(a, np.ndarray):
        return repr(a.tolist()) if a.dtype != object else repr([str(v) for v in a.ravel()])
    if isinstance(a, str):
        return a
    if isinstance(a, np.generic):  # numpy 2's repr would read np.float64(22.7)
        return repr(a.item())
    if isinstance(a, (list, tuple)):
        inner = ", ".join(repr(v) if isinstance(v, str) else _fmt(v) for v in a)
        return f"[{inner}]" if isinstance(a, list) else f"({inner}{',' if len(a) == 1 else ''})"
    return repr(a)


def _is_model(v: Any) -> bool:
    """The certification/property layout ``(algebra name, f, Theta, Upsilon, x, pi)``."""
    return (
        isinstance(v, tuple)
        and len(v) == 6
        and isinstance(v[0], str)
        and all(isinstance(a, np.ndarray) for a in v[1:])
        and [a.ndim for a in v[1:]] == [3, 2, 2, 1, 1]
    )


def _label(v: Any, path: str = "example") -> list[tuple[str, Any]]:
    """Named parts of a drawn example: the model layout gets its mathematical names; a
    float beside a model is the time ``t``, a string or ``None`` beside it the potential."""
    if _is_model(v):
        name, f, theta, ups, x, pi = v
        nz = [
            f"f^{m}_({a},{b}) = {float(f[m, a, b])!r}" for m, a, b in zip(*np.nonzero(f)) if a < b
        ]
        return [
            ("algebra", f"{name} (dimension {f.shape[0]})"),
            ("structure constants (nonzero, a < b)", "; ".join(nz) if nz else "abelian (all zero)"),
            ("Theta", theta),
            ("Upsilon", ups),
            ("x", x),
            ("pi", pi),
        ]
    if isinstance(v, tuple) and hasattr(v, "_fields"):  # a namedtuple: its fields are the labels
        return [
            lab
            for k, p in zip(v._fields, v)
            for lab in (_label(p, k) if isinstance(p, tuple) else [(k, p)])
        ]
    if isinstance(v, tuple):
        has_model = any(_is_model(p) for p in v)
        out: list[tuple[str, Any]] = []
        for i, p in enumerate(v):
            if has_model and isinstance(p, float):
                out.append(("t", p))
            elif has_model and (p is None or isinstance(p, str)):
                out.append(("potential", p))
            else:
                out += _label(p, f"{path}[{i}]")
        return out
    return [(path, v)]


def worst_entry(notes: dict, ratio: float | None) -> dict | None:
    """From recorded ``expected`` and ``got``: the entry with the largest |got - expected|."""
    if "expected" not in notes or "got" not in notes:
        return None
    try:
        exp = np.asarray(notes["expected"], dtype=float)
        got = np.asarray(notes["got"], dtype=float)
        if exp.shape != got.shape or exp.size == 0:
            return None
        diff = np.abs(got - exp)
        diff = np.where(np.isnan(diff), np.inf, diff)
        idx = np.unravel_index(int(np.argmax(diff)), diff.shape)
    except (TypeError, ValueError):
        return None
    out: dict[str, Any] = {
        "index": [int(i) for i in idx],
        "expected": float(exp[idx]),
        "got": float(got[idx]),
        "error": float(diff[idx]),
    }
    if "tolerance" in notes:
        out["tolerance"] = float(notes["tolerance"])
    elif ratio is not None and math.isfinite(ratio) and ratio > 0 and math.isfinite(out["error"]):
        out["tolerance"] = out["error"] / ratio
        out["tolerance_from"] = "error / ratio"
    if ratio is not None:
        out["ratio"] = ratio
    return out


def _record_failure(example: Any, notes: dict, ratio: float | None, error: str) -> dict:
    data = {
        "values": encode(example),
        "ratio": encode(ratio),
        "error": error,
        "notes": {k: encode(v) for k, v in notes.items()},
    }
    worst = worst_entry(notes, ratio)
    if worst is not None:
        data["worst_entry"] = worst
    data["text"] = render_example(example, notes, ratio, error, worst)
    return data


def render_example(
    example: Any,
    notes: dict | None = None,
    ratio: float | None = None,
    error: str = "",
    worst: dict | None = None,
) -> str:
    """The failing example as text, from the drawn values (independent of Hypothesis' report)."""
    notes = notes or {}
    lines = ["falsifying example (drawn values, rendered by tstarg):"]
    for label, value in _label(example):
        lines.append(f"  {label} = {_fmt(value)}")
    call = notes.get("call")
    if isinstance(call, dict) and "method" in call:
        lines.append(f"  implementation called: {call['method']}")
    if worst is None:
        worst = worst_entry(notes, ratio)
    if worst is not None:
        idx = ",".join(str(i) for i in worst["index"])
        what = notes.get("what", "result")
        tol = worst.get("tolerance")
        lines.append(
            f"  worst entry {what}[{idx}]: expected {worst['expected']!r}, got {worst['got']!r}, "
            f"error {worst['error']:.3e}"
            + (
                ""
                if tol is None
                else f", tolerance {tol:.3e}"
                + (" (error / ratio)" if worst.get("tolerance_from") else "")
            )
            + ("" if ratio is None else f", ratio {ratio:.3g}")
        )
    elif ratio is not None:
        lines.append(f"  error/tolerance ratio = {ratio:.3g}")
    for k, v in notes.items():
        if k in ("expected", "got", "tolerance", "call", "what"):
            continue
        lines.append(f"  {k} = {_fmt(v)}")
    if error:
        lines.append(f"  raised: {error}")
    return "\n".join(lines)


# ------------------------------------------------------------------ the runner
class _Stop(BaseException):
    """The check's budget is used up: end the Hypothesis run now (not a failure by itself)."""


def _failure_kind(exc: BaseException) -> str:
    """A failure's kind: its type and message with the numbers taken out."""
    return type(exc).__name__ + re.sub(r"[-+0-9.eE]+", "#", str(exc))[:120]


def _strip_notes(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"[:2000]


def run_property(
    name: str,
    equations: str,
    body: Callable[[Any], tuple[float, float | None]],
    strategy: st.SearchStrategy,
    *,
    max_examples: int,
    seed: int | None = 0,
    extra: dict | None = None,
    example_seconds: float | None = None,
    check_seconds: float | None = None,
    shrink_seconds: float | None = None,
    explicit: tuple = (),
) -> CheckResult:
    """Run ``body`` over ``strategy`` with Hypothesis; a ratio above 1 is a failure, shrunk to a minimal example.

    ``explicit``: examples run first, before any drawn one (Hypothesis' ``@example``): the cases a
    check must always see whatever the seed and the example budget (they count in ``max_examples``'s
    report like any other, and a failing one is reported as it is, unshrunk).

    ``body`` may return ``None`` to skip an example (e.g. a point exactly on the degenerate set).
    ``example_seconds`` / ``check_seconds`` default to the budgets of :func:`current` (see the
    module docstring).
    """
    res = CheckResult(name=name, equations=equations, extra=dict(extra or {}))
    state_now = current()
    lim, replay = state_now.limits, state_now.replay
    ex_s = example_seconds if example_seconds is not None else lim.example_seconds
    ck_s = check_seconds if check_seconds is not None else lim.check_seconds
    if lim.deadline is not None:
        left = max(1e-3, lim.deadline - time.time())
        ck_s = left if ck_s is None else min(ck_s, left)
    sh_s = shrink_seconds if shrink_seconds is not None else lim.shrink_seconds
    t0 = time.perf_counter()
    state: dict[str, Any] = {
        "failure": None,
        "over": 0,
        "stopped": False,
        "example_seconds": ex_s,
        "first_failure": None,
        "kind": None,
    }
    if replay and name not in replay:
        res.extra["not_replayed"] = True
        return res
    _report("start", name, 0, max_examples)

    def one(example):
        notes: dict = {}
        token = _NOTES.set(notes)
        ratio = None
        try:
            try:
                with time_limit(ex_s, "example"):
                    out = body(example)
            except TimeLimitExceeded as exc:
                if exc.what != "example":
                    raise
                state["over"] += 1
                return
            if out is None:
                res.skipped += 1
                return
            ratio, digits = out
            ratio = float(ratio)
            res.examples += 1
            _report("example", name, res.examples, max_examples)
            res.worst_ratio = max(
                res.worst_ratio, ratio if ratio <= 1.0 or ratio > 1.0 else math.inf
            )
            if digits is not None:
                res.min_digits = digits if res.min_digits is None else min(res.min_digits, digits)
            assert ratio <= 1.0, f"{name}: error/tolerance ratio {ratio:.3g} > 1"
        except (KeyboardInterrupt, _Stop, UnsatisfiedAssumption):
            raise  # a reject() in the body draws again: no failure (it must not start shrinking)
        except BaseException as exc:
            # while shrinking, only failures of the first one's kind replace it (a call that times out
            # on a larger model the shrinker tried is another failure, not a smaller example of it)
            kind = _failure_kind(exc)
            if state["failure"] is None or kind == state["kind"]:
                state["failure"] = _record_failure(example, notes, ratio, _strip_notes(exc))
                state["kind"] = kind
            if state["first_failure"] is None:
                state["first_failure"] = time.perf_counter()
            if isinstance(
                exc, SystemExit
            ):  # Hypothesis treats it as a failure: keep it one, clearly
                raise AssertionError(f"the check called sys.exit({exc.code!r})") from exc  # noqa: TRY004
            raise
        finally:
            _NOTES.reset(token)

    if name in replay:
        res.extra["replayed"] = True
        try:
            one(replay[name])
        except (KeyboardInterrupt, _Stop):
            raise
        except BaseException as exc:  # noqa: BLE001 - the verdict
            res.passed = False
            res.detail = _strip_notes(exc)
        return _finish(res, state, t0, max_examples)

    @settings(
        max_examples=max_examples,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
        print_blob=False,
    )
    @given(strategy)
    def inner(example):
        now = time.perf_counter()
        if ck_s is not None and now - t0 > ck_s:
            state["stopped"] = True
            raise _Stop(f"the check's budget of {ck_s:g} s")
        if (
            sh_s is not None
            and state["first_failure"] is not None
            and now - state["first_failure"] > sh_s
        ):
            raise _Stop(f"the shrinking budget of {sh_s:g} s")
        one(example)

    for ex in reversed(tuple(explicit)):
        inner = hyp_example(ex)(inner)
    if seed is not None:
        inner = hyp_seed(seed)(inner)
    buf = io.StringIO()

    def to_buffer(text: object) -> None:
        buf.write(str(text) + "\n")

    try:
        with with_reporter(to_buffer):
            inner()
    except _Stop as stop:
        if state["failure"] is not None:
            res.passed = False
            res.detail = (
                f"{state['failure']['error']} (shrinking stopped at {stop}: "
                "the example below is the smallest failing one found by then)"
            )
    except KeyboardInterrupt:
        raise
    except Unsatisfiable as exc:
        res.passed = res.examples > 0
        res.detail = f"unsatisfiable: {exc}"
    except CheckAborted as exc:
        res.passed = False
        res.worst_ratio = math.inf  # not judged to the end: no ratio may read as a pass
        res.detail = f"check aborted: {exc}"[:2000]
    except BaseException as exc:  # noqa: BLE001 - any failure of the check is its verdict
        res.passed = False
        res.detail = _strip_notes(exc)
        if state["failure"] is None:  # raised outside the body: while drawing the example
            res.worst_ratio = math.inf
            # the innermost frames (where it was raised: the strategy's own code) and the error itself
            frames = traceback.extract_tb(exc.__traceback__)[-4:]
            tb = "".join(traceback.format_list(frames)) + "".join(
                traceback.format_exception_only(type(exc), exc)
            )
            res.falsifying_example = (
                "no example to show: this was raised outside the check's body, while "
                "drawing an example (in the strategy) or inside Hypothesis itself:\n" + tb
            )[:8000]
    if buf.getvalue():
        res.extra["hypothesis_output"] = (
            "(Hypothesis' own report, not the example) " + buf.getvalue()
        )[:4000]
    return _finish(res, state, t0, max_examples, ck_s)


def _finish(
    res: CheckResult, state: dict, t0: float, max_examples: int, ck_s: float | None = None
) -> CheckResult:
    if state["over"]:
        res.extra["over_budget"] = state["over"]
    if state["stopped"]:
        res.extra["stopped_at_budget"] = ck_s
    if state["failure"] is not None and not res.passed:
        res.falsifying_example = state["failure"]["text"][:8000]
        res.extra["example"] = {k: v for k, v in state["failure"].items() if k != "text"}
    if not res.passed and not res.worst_ratio > 1.0:
        # a failed check never reads as within tolerance: its failing example's ratio when the body
        # returned one above 1 (already in worst_ratio), else (it raised) the ratio that example
        # recorded (returned, or noted as ``ratio``) when above 1, else inf -- the column is "the
        # largest error / tolerance seen"
        fail = state["failure"] or {}
        fr = next(
            (
                r
                for r in (fail.get("ratio"), fail.get("notes", {}).get("ratio"))
                if isinstance(r, (int, float)) and r > 1.0
            ),
            math.inf,
        )
        res.worst_ratio = float(fr)
    if res.passed and res.examples == 0 and state["stopped"] and not state["over"]:
        res.passed = False
        res.worst_ratio = math.inf
        res.detail = (
            f"nothing verified: the budget left for this check ({ck_s:.3g} s, the check's own or what "
            "remained of the run's) was used up before any example finished"
        )
    if res.passed and res.examples == 0 and state["over"]:
        res.passed = False
        res.worst_ratio = math.inf
        res.detail = (
            f"nothing verified: all {state['over']} examples ran over the per-example budget "
            f"({state['example_seconds']} s)"
        )
    res.seconds = time.perf_counter() - t0
    _report("done", res.name, res.examples, max_examples, res)
    return res


def _report(event, name, done, total, result=None) -> None:
    for listener in current().listeners:
        listener(event, name, done, total, result)


def announce(name: str, total: int = 1) -> None:
    """A check that does not go through :func:`run_property` (a single computation, a speed
    row, a certificate) starts: the progress listeners show it as the current step."""
    _report("start", name, 0, total)


def advance(name: str, done: int, total: int) -> None:
    """The check announced by :func:`announce` has done ``done`` of its ``total`` steps."""
    _report("example", name, done, total)


def finished(result: CheckResult, total: int | None = None) -> CheckResult:
    """The check announced by :func:`announce` is done: the listeners print its line.
    Returns ``result`` (so a provider can ``return finished(CheckResult(...))``)."""
    _report(
        "done", result.name, result.examples, result.examples if total is None else total, result
    )
    return result
