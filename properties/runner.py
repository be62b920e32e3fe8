"""The check runner: property checks usable outside pytest, each returning a :class:`CheckResult`.

A check is a function of one drawn example that returns ``(ratio, digits)``:
``ratio`` is the worst error / tolerance (a pass needs ``ratio <= 1``) and
``digits`` the correct significant digits where that is meaningful. The
runner :func:`run_property` drives it with Hypothesis (shrinking a failure to
a minimal example) and records the number of examples, the worst ratio and
the falsifying example. properties, oracles and reports all use this one runner.
"""

from __future__ import annotations

import io
import math
import time
from dataclasses import asdict, dataclass, field
from typing import Any, Callable

from hypothesis import HealthCheck, given, settings
from hypothesis import seed as hyp_seed
from hypothesis import strategies as st
from hypothesis.errors import Unsatisfiable

__all__ = ["CheckResult", "run_property", "PROGRESS"]


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


def run_property(name: str, equations: str, body: Callable[[Any], tuple[float, float | None]],
                 strategy: st.SearchStrategy, *, max_examples: int, seed: int | None = 0,
                 extra: dict | None = None) -> CheckResult:
    """Run ``body`` over ``strategy`` with Hypothesis; a ratio above 1 is a failure, shrunk to a minimal example.

    ``body`` may return ``None`` to skip an example (e.g. a point exactly on the degenerate set).
    """
    res = CheckResult(name=name, equations=equations, extra=dict(extra or {}))
    t0 = time.perf_counter()
    _report("start", name, 0, max_examples)

    @settings(max_examples=max_examples, deadline=None, database=None,
              suppress_health_check=list(HealthCheck), print_blob=False)
    @given(strategy)
    def inner(example):
        out = body(example)
        if out is None:
            res.skipped += 1
            return
        ratio, digits = out
        res.examples += 1
        _report("example", name, res.examples, max_examples)
        res.worst_ratio = max(res.worst_ratio, float(ratio))
        if digits is not None:
            res.min_digits = digits if res.min_digits is None else min(res.min_digits, digits)
        assert ratio <= 1.0, f"{name}: error/tolerance ratio {ratio:.3g} > 1"

    if seed is not None:
        inner = hyp_seed(seed)(inner)
    buf = io.StringIO()
    from hypothesis.reporting import with_reporter

    try:
        with with_reporter(lambda s: buf.write(str(s) + "\n")):
            inner()
    except Unsatisfiable as exc:
        res.passed = res.examples > 0
        res.detail = f"unsatisfiable: {exc}"
    except Exception as exc:  # noqa: BLE001 - any failure of the check is its verdict
        res.passed = False
        res.detail = f"{type(exc).__name__}: {exc}"[:2000]
        res.falsifying_example = buf.getvalue()[:4000]
    res.seconds = time.perf_counter() - t0
    _report("done", name, res.examples, max_examples, res)
    return res


PROGRESS: list = []
"""Progress listeners: callables ``(event, name, done, total, result=None)`` with ``event`` in
``"start"``, ``"example"``, ``"done"``. ``tstarg verify`` registers its progress bar here."""


def _report(event, name, done, total, result=None) -> None:
    for listener in list(PROGRESS):
        listener(event, name, done, total, result)


