"""The worker of ``tstarg verify`` (:mod:`reports.cmd_verify` parses the arguments and calls
:func:`main`): run the check providers, compare with the baseline, write the report."""

from __future__ import annotations

import json
import math
import platform
import sys
import time
import traceback
from pathlib import Path

import hypothesis
import mpmath
import numpy
import scipy
import sympy
from threadpoolctl import threadpool_info, threadpool_limits

from tstarg.properties import runner
from tstarg.properties.profiles import PROFILES as _PROFILES

from . import _progress, regression
from ._atomic import claim_output, write_text
from ._imports import import_module
from .junit import write_junit

PROFILES = {name: p["verify_examples"] for name, p in _PROFILES.items()}  # properties.profiles
BUDGETS = {
    "dev": {
        "example_seconds": 20.0,
        "check_seconds": 60.0,
        "shrink_seconds": 20.0,
        "run_seconds": 1800.0,
    },
    "ci": {
        "example_seconds": 30.0,
        "check_seconds": 120.0,
        "shrink_seconds": 30.0,
        "run_seconds": 5400.0,
    },
    "thorough": {
        "example_seconds": 60.0,
        "check_seconds": 600.0,
        "shrink_seconds": 120.0,
        "run_seconds": 21600.0,
    },
}
"""Wall-clock budgets by profile (:mod:`properties.runner` limits): one example (reference
computation included; longer ones are drawn again and counted as ``over_budget``), one check,
shrinking after the first failure, and the whole run -- the stated time of ``tstarg verify``
per profile: dev 30 min, ci 90 min, thorough 6 h at most, on a machine whose cores are not
oversubscribed (measured: dev takes 8-16 min of wall time at a load of 5-6 per core, about
200 s of CPU). Checks that would start after the run's budget is used up report that nothing
was verified, and fail: a run out of time says so instead of passing."""

PROVIDERS = (
    "tstarg.properties.core_checks:core_checks",
    "tstarg.properties.identity_checks:identity_checks",
    "tstarg.oracles.oracle_checks:oracle_checks",
    "tstarg.reports.certification:certificate_checks",
    "tstarg.reports.speed_checks:speed_checks",
)
"""Check providers, in order: ``module:function`` with ``function(max_examples, seed) -> [CheckResult]``."""


def _load_provider(spec: str):
    """``"module:function"`` -> callable, or None when the module does not exist."""
    if spec.count(":") != 1:
        raise ValueError(f"provider must be 'module:function', got {spec!r}")
    mod_name, fn_name = spec.split(":")
    try:
        mod = import_module(mod_name)
    except ModuleNotFoundError as exc:
        if exc.name and (mod_name == exc.name or mod_name.startswith(exc.name + ".")):
            return None
        raise
    try:
        return getattr(mod, fn_name)
    except AttributeError:
        raise ValueError(f"provider {spec!r}: module {mod_name} has no {fn_name}") from None


class Progress:
    """The listener of :data:`properties.runner.PROGRESS` that drives a display of
    :mod:`reports._progress`: a check that starts is the current step (its examples counted),
    a check that is done prints one kept line ``N ex  T s  PASS``.

    ``display``: an open :class:`reports._progress.Progress`; without one, a plain display on
    stdout is opened (timestamped lines, no heartbeat -- for callers that do not manage one)."""

    def __init__(self, display=None):
        if display is None:
            display = _progress.Progress("verify", mode="plain", heartbeat=1e9).open()
        self.display = display
        self._stack: list[str] = []

    def phase(self, text: str) -> None:
        """A stage between checks (importing a provider): shown, not counted."""
        self.display.phase(text)

    def __call__(self, event, name, done, total, result=None):
        if event == "start":
            self._stack.append(name)
            if len(self._stack) == 1:
                self.display.start(name, total)
            else:  # a check inside a check (the certificate's own checks): shown, not counted
                self.display.start(f"{self._stack[0]}: {name}", total)
        elif event == "example":
            self.display.update(done, total)
        elif event == "done":
            if self._stack and self._stack[-1] == name:
                self._stack.pop()
            if self._stack:
                return
            verdict = "PASS" if result is None or result.passed else "FAIL"
            over = (result.extra.get("over_budget", 0) if result else 0) or 0
            secs = result.seconds if result else 0.0
            self.display.done(
                name,
                f"{done:d} ex, {secs:.1f} s, {verdict}"
                + (f" ({over} examples over the per-example budget, drawn again)" if over else ""),
            )


def expected_checks(specs, base: dict | None) -> tuple[int | None, float | None]:
    """How many checks the providers ``specs`` ran in the baseline report ``base`` (as read by
    :func:`_load_baseline`), and its wall time (``(None, None)`` without a baseline): the progress
    display's total, and the expected duration printed in the header."""
    if not base:
        return None, None
    n = sum(
        1
        for c in base.get("checks", [])
        if c.get("extra", {}).get("provider") in specs and not c["name"].startswith("regression.")
    )
    return (n or None), base.get("seconds")


def _env() -> dict:
    return {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "mpmath": mpmath.__version__,
        "mpmath_backend": mpmath.libmp.BACKEND,
        "sympy": sympy.__version__,
        "hypothesis": hypothesis.__version__,
        "blas_threads": [(i.get("internal_api"), i.get("num_threads")) for i in threadpool_info()],
    }


def _fmt_ratio(r: float) -> str:
    return "inf" if not math.isfinite(r) else f"{r:.3g}"


def _fmt_digits(d) -> str:
    if d is None:
        return "-"
    return "exact" if not math.isfinite(d) else f"{d:.1f}"


def render_table(results) -> str:
    """The summary table: check, equations, examples, worst error/tolerance ratio, digits, time, verdict."""
    w = max([5] + [len(r.name) for r in results])
    we = max([9] + [len(r.equations) for r in results])
    head = (
        f"{'check':{w}s} {'equations':{we}s} {'examples':>8s} {'skipped':>7s} {'worst ratio':>12s} "
        f"{'digits':>7s} {'time':>7s}  verdict"
    )
    lines = [head, "-" * len(head)]
    for r in results:
        verdict = "PASS" if r.passed else "FAIL"
        lines.append(
            f"{r.name:{w}s} {r.equations:{we}s} {r.examples:8d} {r.skipped:7d} {_fmt_ratio(r.worst_ratio):>12s} "
            f"{_fmt_digits(r.min_digits):>7s} {r.seconds:6.1f}s  {verdict}"
        )
    return "\n".join(lines)


def render_markdown(report: dict) -> str:
    out = [
        "# tstarg verification report",
        "",
        f"- profile: `{report['profile']}`, max examples per check: {report['max_examples']}, seed: {report['seed']}",
        f"- verdict: **{'PASS' if report['passed'] else 'FAIL'}** ({report['n_failed']} failed of {len(report['checks'])})",
        f"- wall time: {report['seconds']:.1f} s; BLAS pinned to one thread ({report['environment']['blas_threads']})",
        *[f"- provider `{k}`: {v}" for k, v in report.get("providers", {}).items()],
        *(
            [
                (
                    f"- slowest check: `{report['slowest_check']['name']}` ({report['slowest_check']['seconds']:.1f} s); "
                    f"examples over the per-example budget (drawn again): {report.get('over_budget_examples', 0)}"
                )
            ]
            if report.get("slowest_check")
            else []
        ),
        "",
        "| check | equations | examples | skipped | worst error/tolerance | min digits | verdict |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for c in report["checks"]:
        ratio = float(c["worst_ratio"])  # "inf" is stored as a string in JSON
        digits = None if c["min_digits"] is None else float(c["min_digits"])
        out.append(
            f"| {c['name']} | {c['equations']} | {c['examples']} | {c['skipped']} | {_fmt_ratio(ratio)} | "
            f"{_fmt_digits(digits)} | {'PASS' if c['passed'] else 'FAIL'} |"
        )
    cmp = report.get("comparison")
    if cmp:
        out += [
            "",
            "## Against the baseline",
            "",
            f"Baseline `{cmp['base']}`: {'**REGRESSED**' if cmp['regressed'] else 'no regression'} "
            f"(accuracy slack {cmp['digits_slack']:g} digits, speed factor {cmp['speed_factor']:g}x"
            + ("" if cmp["same_sampling"] else "; different samples, digits not enforced")
            + "). "
            "Full table: [compare.md](compare.md).",
            *(["", f"**{cmp['stale_note']}**"] if cmp.get("stale") else []),
            "",
            "![base vs this run](figures/compare.png)",
            "",
        ]
        changed = [r for r in cmp["rows"] if r["status"]]
        if changed:
            out += ["| check | status |", "|---|---|"] + [
                f"| {r['name']} | {'; '.join(r['status'])} |" for r in changed
            ]
    elif report.get("baseline_note"):
        out += ["", f"Baseline: {report['baseline_note']}"]
    fails = [c for c in report["checks"] if not c["passed"]]
    if fails:
        out += ["", "## Failures", ""]
        for c in fails:
            out += [f"### {c['name']}", "", "```", c["detail"], c["falsifying_example"], "```", ""]
    out += ["", "## Environment", "", "```", json.dumps(report["environment"], indent=2), "```", ""]
    return "\n".join(out)


def run_providers(specs, max_examples: int, seed, progress=None, optional=PROVIDERS):
    """Run each provider; returns ``(results, provider_status)``. A missing module of an
    ``optional`` provider (the defaults: other issues may not be merged yet) is ``"skipped"``;
    a missing requested provider, or one that raises, becomes a failed :class:`CheckResult`."""

    results, status = [], {}
    if progress is not None:
        runner.PROGRESS.append(progress)
    try:
        for spec in specs:
            if hasattr(progress, "phase"):
                progress.phase(f"loading {spec}")
            fn = _load_provider(spec)
            if fn is None and spec in optional:
                status[spec] = "skipped: module not found"
                continue
            t0 = time.perf_counter()
            try:
                if fn is None:
                    raise ModuleNotFoundError(
                        f"provider {spec}: module {spec.split(':')[0]} not found"
                    )
                got = list(fn(max_examples, seed))
            except Exception as exc:  # noqa: BLE001 - a crashing provider is a failed check
                got = [
                    runner.CheckResult(
                        name=f"provider[{spec}]",
                        equations="-",
                        passed=False,
                        worst_ratio=math.inf,
                        detail=f"{type(exc).__name__}: {exc}"[:2000],
                        falsifying_example=traceback.format_exc()[-4000:],
                    )
                ]
            bad = [r for r in got if not isinstance(r, runner.CheckResult)]
            if bad:
                raise TypeError(
                    f"provider {spec} returned {type(bad[0]).__name__}, expected CheckResult"
                )
            for r in got:
                r.extra.setdefault("provider", spec)
                if not r.passed and isinstance(r.extra.get("example"), dict):
                    r.extra["example"]["replay"] = (
                        f"tstarg verify --provider {spec} --seed {seed} "
                        f"--max-examples {max_examples} --no-baseline"
                    )
            results.extend(got)
            status[spec] = f"ran {len(got)} checks in {time.perf_counter() - t0:.1f} s"
    finally:
        if progress is not None:
            runner.PROGRESS.remove(progress)
    return results, status


def _budget(args) -> dict:
    out = dict(BUDGETS[args.profile])
    for k in out:
        v = getattr(args, k, None)
        if v is not None:
            if not (math.isfinite(v) and v > 0):
                raise ValueError(
                    f"--{k.replace('_', '-')} must be a positive number of seconds, got {v}"
                )
            out[k] = float(v)
    return out


def main(args) -> int:
    threadpool_limits(1)
    if args.max_examples is not None and args.max_examples < 1:
        raise ValueError(f"--max-examples must be >= 1, got {args.max_examples}")
    max_examples = args.max_examples or PROFILES[args.profile]
    specs = tuple(args.provider) if getattr(args, "provider", None) else PROVIDERS
    for spec in specs:
        if spec.count(":") != 1:
            raise ValueError(f"--provider must be 'module:function', got {spec!r}")
    budget = _budget(args)
    try:  # the baseline is read FIRST: a corrupt one stops the run before any check (issue 30)
        baseline = _load_baseline(args)
    except (ValueError, OSError) as exc:
        print(f"tstarg verify: --baseline: {exc}", file=sys.stderr)
        return 2
    n_expected, base_seconds = expected_checks(specs, baseline)
    print(
        f"tstarg verify: profile {args.profile}, {max_examples} examples per check, seed {args.seed}; "
        f"budgets: example {budget['example_seconds']:g} s, check {budget['check_seconds']:g} s, "
        f"shrinking {budget['shrink_seconds']:g} s, run {budget['run_seconds']:g} s; BLAS pinned to 1 thread"
        + (
            f"\nthe baseline ran {n_expected} of these checks in {base_seconds:.0f} s (profile ci)"
            if n_expected and base_seconds
            else ""
        ),
        flush=True,
    )
    t0 = time.perf_counter()

    with _progress.Progress("verify", total=n_expected, quiet=_progress.is_quiet(args)) as display:
        with runner.limits(**budget):
            results, status = run_providers(specs, max_examples, args.seed, Progress(display))
        display.phase("comparing with the baseline and writing the report")
        total = time.perf_counter() - t0
        out, failed, slowest, over = _write_report(
            args, results, status, total, max_examples, budget, baseline
        )
    print(render_table(results))
    return _finish(results, status, out, failed, slowest, over, total)


def _write_report(args, results, status, total, max_examples, budget, baseline=None):
    """Compare with the baseline and write report.json, report.md, the junit file (and the
    baseline with ``--write-baseline``); returns ``(out, failed, slowest, over)``."""
    slowest = max(results, key=lambda r: r.seconds, default=None)
    over = sum(int(r.extra.get("over_budget", 0) or 0) for r in results)
    report = {
        "tool": "tstarg verify",
        "profile": args.profile,
        "max_examples": max_examples,
        "seed": args.seed,
        "seconds": total,
        "providers": status,
        "checks": [r.to_json() for r in results],
        "environment": _env(),
        "budgets": budget,
        "over_budget_examples": over,
        "slowest_check": None
        if slowest is None
        else {"name": slowest.name, "seconds": slowest.seconds},
        "command": " ".join(["tstarg"] + sys.argv[1:]),
    }
    out = claim_output(Path(args.out))  # issue 15: a concurrent run gets its own folder and says so
    _compare_with_baseline(args, report, results, out, baseline)
    failed = [r for r in results if not r.passed]
    report.update(passed=not failed, n_failed=len(failed))
    write_text(out / "report.json", json.dumps(report, indent=2))
    write_text(out / "report.md", render_markdown(report))
    write_junit(report, out / "report.junit.xml")
    if getattr(args, "write_baseline", False):
        regression.BASELINE.parent.mkdir(parents=True, exist_ok=True)
        kept = dict(
            report, checks=[c for c in report["checks"] if not c["name"].startswith("regression.")]
        )
        kept.pop("comparison", None)
        kept.pop("baseline_note", None)
        kept_failed = [c["name"] for c in kept["checks"] if not c["passed"]]
        kept.update(passed=not kept_failed, n_failed=len(kept_failed))  # its own checks' verdict
        if kept_failed:
            print(f"note: the baseline records failing checks: {', '.join(kept_failed)}")
        write_text(
            regression.BASELINE, json.dumps(kept, indent=2)
        )  # atomic: the old baseline stays until this is whole
        print(f"baseline written: {regression.BASELINE}")
    return out, failed, slowest, over


def _finish(results, status, out, failed, slowest, over, total) -> int:
    for spec, st in status.items():
        print(f"provider {spec}: {st}")
    print(
        f"\n{len(results) - len(failed)} passed, {len(failed)} failed in {total:.1f} s; report: {out / 'report.md'}"
    )
    if slowest is not None:
        print(
            f"slowest check: {slowest.name} ({slowest.seconds:.1f} s); examples over the per-example budget "
            f"(drawn again): {over}"
        )
    for r in failed:
        print(f"\nFAILED {r.name}: {r.detail}\n{r.falsifying_example}")
    return 1 if failed else 0


def _load_baseline(args) -> dict | None:
    """The baseline report (None: ``--no-baseline``, or no committed baseline); read before any
    check runs, so that a corrupt one costs nothing."""

    if getattr(args, "no_baseline", False):
        return None
    path = getattr(args, "baseline", None) or regression.BASELINE
    if getattr(args, "baseline", None) is None and not Path(path).exists():
        return None
    return regression.load_report(path)


def _compare_with_baseline(args, report: dict, results: list, out: Path, base=None) -> None:
    """Compare with the baseline (unless ``--no-baseline``): add the two regression rows to
    ``results`` and ``report``, write ``compare.md`` and ``figures/compare.png``."""

    if getattr(args, "no_baseline", False):
        report["baseline_note"] = "not compared (--no-baseline)"
        return
    path = getattr(args, "baseline", None) or regression.BASELINE
    if base is None:
        report["baseline_note"] = f"no baseline at {path}: not compared"
        print(f"no baseline at {path}: not compared")
        return
    slack = getattr(args, "digits_slack", None)
    slack = regression.DIGITS_SLACK if slack is None else slack
    factor = getattr(args, "speed_factor", None)
    factor = regression.SPEED_FACTOR if factor is None else factor
    cmp = regression.compare(
        base, dict(report, _path=str(out / "report.json")), digits_slack=slack, speed_factor=factor
    )
    rows = regression.regression_checks(cmp)
    results.extend(rows)
    report["checks"].extend(r.to_json() for r in rows)
    report["comparison"] = cmp
    regression.plot(cmp, out / "figures" / "compare.png")
    write_text(out / "compare.md", regression.render_markdown(cmp, figure="figures/compare.png"))
    print(
        f"against baseline {path}: {'REGRESSED' if cmp['regressed'] else 'no regression'}"
        + (
            f" (accuracy: {cmp['accuracy_regressions']}; speed: {cmp['speed_regressions']})"
            if cmp["regressed"]
            else ""
        )
    )
    if cmp.get("stale"):
        print(cmp["stale_note"])
