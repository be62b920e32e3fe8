"""``tstarg verify``: the main job -- run the checks, print a summary table, write a report.

Writes ``report.json`` (every check with its metrics, the environment, versions,
seed, profile) and ``report.md`` into the output folder (default
``reports/latest``). Exit status 1 when any check fails.
"""

from __future__ import annotations

import json
import math
import os
import platform
import sys
import time
from pathlib import Path

PROFILES = {"dev": 6, "ci": 12, "thorough": 60}


def _env() -> dict:
    import hypothesis
    import mpmath
    import numpy
    import scipy
    import sympy
    from threadpoolctl import threadpool_info

    return {
        "python": sys.version.split()[0], "platform": platform.platform(), "numpy": numpy.__version__,
        "scipy": scipy.__version__, "mpmath": mpmath.__version__, "mpmath_backend": mpmath.libmp.BACKEND,
        "sympy": sympy.__version__, "hypothesis": hypothesis.__version__,
        "blas_threads": [(i.get("internal_api"), i.get("num_threads")) for i in threadpool_info()],
    }


def _fmt_ratio(r: float) -> str:
    return "inf" if not math.isfinite(r) else f"{r:.3g}"


def _fmt_digits(d) -> str:
    if d is None:
        return "-"
    return "exact" if not math.isfinite(d) else f"{d:.1f}"


def render_table(results) -> str:
    head = f"{'check':38s} {'equations':16s} {'examples':>8s} {'worst ratio':>12s} {'digits':>7s} {'time':>7s}  verdict"
    lines = [head, "-" * len(head)]
    for r in results:
        verdict = "PASS" if r.passed else "FAIL"
        lines.append(f"{r.name:38s} {r.equations:16s} {r.examples:8d} {_fmt_ratio(r.worst_ratio):>12s} "
                     f"{_fmt_digits(r.min_digits):>7s} {r.seconds:6.1f}s  {verdict}")
    return "\n".join(lines)


def render_markdown(report: dict) -> str:
    out = ["# tstarg verification report", "",
           f"- profile: `{report['profile']}`, max examples per check: {report['max_examples']}, seed: {report['seed']}",
           f"- verdict: **{'PASS' if report['passed'] else 'FAIL'}** ({report['n_failed']} failed of {len(report['checks'])})",
           f"- wall time: {report['seconds']:.1f} s; BLAS pinned to one thread ({report['environment']['blas_threads']})",
           "", "| check | equations | examples | skipped | worst error/tolerance | min digits | verdict |",
           "|---|---|---:|---:|---:|---:|---|"]
    for c in report["checks"]:
        out.append(f"| {c['name']} | {c['equations']} | {c['examples']} | {c['skipped']} | {c['worst_ratio']} | "
                   f"{c['min_digits'] if c['min_digits'] is not None else '-'} | {'PASS' if c['passed'] else 'FAIL'} |")
    fails = [c for c in report["checks"] if not c["passed"]]
    if fails:
        out += ["", "## Failures", ""]
        for c in fails:
            out += [f"### {c['name']}", "", "```", c["detail"], c["falsifying_example"], "```", ""]
    out += ["", "## Environment", "", "```", json.dumps(report["environment"], indent=2), "```", ""]
    return "\n".join(out)


def main(args) -> int:
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
    from properties.checks import core_checks

    max_examples = args.max_examples or PROFILES[args.profile]
    print(f"tstarg verify: profile {args.profile}, {max_examples} examples per check, seed {args.seed}; "
          f"BLAS pinned to 1 thread", flush=True)
    t0 = time.perf_counter()
    results = core_checks(max_examples=max_examples, seed=args.seed)
    total = time.perf_counter() - t0
    print(render_table(results))
    failed = [r for r in results if not r.passed]
    report = {
        "tool": "tstarg verify", "profile": args.profile, "max_examples": max_examples, "seed": args.seed,
        "passed": not failed, "n_failed": len(failed), "seconds": total,
        "checks": [r.to_json() for r in results], "environment": _env(),
        "command": " ".join(["tstarg"] + sys.argv[1:]),
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").write_text(json.dumps(report, indent=2))
    (out / "report.md").write_text(render_markdown(report))
    print(f"\n{len(results) - len(failed)} passed, {len(failed)} failed in {total:.1f} s; report: {out / 'report.md'}")
    for r in failed:
        print(f"\nFAILED {r.name}: {r.detail}\n{r.falsifying_example}")
    return 1 if failed else 0
