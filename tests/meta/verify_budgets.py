"""Benchmark script (not a test): ``tstarg verify`` under several seeds and profiles finishes
within the profile's stated time (``reports._verify.BUDGETS[profile]["run_seconds"]``).

Usage::

    PYTHONPATH=... python tests/meta/verify_budgets.py --profiles dev ci --seeds 1 2 3 4 5 [--out DIR]

Runs each ``python -m tstarg.reports.cli verify --profile P --seed S --no-baseline`` in a
subprocess, one at a time, and prints per run: wall time, CPU time of the child, the stated
budget, exit status, the slowest check and the number of examples drawn again because they
ran over the per-example budget. A run is "within" when its wall time is at most the budget
(plus 60 s for start-up and report writing).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

from tstarg.reports._verify import BUDGETS


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--profiles", nargs="+", default=["dev"], choices=sorted(BUDGETS))
    ap.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3, 4, 5])
    ap.add_argument("--out", default="/tmp/tstarg-verify-budgets")
    a = ap.parse_args()
    rows, ok = [], True
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    for profile in a.profiles:
        for seed in a.seeds:
            out = Path(a.out) / f"{profile}-seed{seed}"
            budget = BUDGETS[profile]["run_seconds"]
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            proc = subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "tstarg.reports.cli",
                    "verify",
                    "--profile",
                    profile,
                    "--seed",
                    str(seed),
                    "--no-baseline",
                    "--quiet",
                    "--out",
                    str(out),
                ],
                check=False,
                env=env,
                capture_output=True,
                text=True,
                timeout=budget + 600,
            )
            wall = time.perf_counter() - t0
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
            rep = (
                json.loads((out / "report.json").read_text())
                if (out / "report.json").exists()
                else {}
            )
            slow = rep.get("slowest_check") or {}
            within = wall <= budget + 60
            ok &= within
            row = (
                f"{profile:8s} seed {seed:3d}: wall {wall:7.1f} s, cpu {cpu:7.1f} s, budget {budget:6.0f} s, "
                f"{'within' if within else 'OVER'}; exit {proc.returncode}; slowest {slow.get('name')} "
                f"({slow.get('seconds', 0):.1f} s); over-budget examples {rep.get('over_budget_examples')}; "
                f"failed {rep.get('n_failed')}"
            )
            print(row, flush=True)
            rows.append(row)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
