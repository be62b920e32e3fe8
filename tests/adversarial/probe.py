"""The adversarial probe of issue 30 for the harness's entry points: ``python tests/adversarial/probe.py
[--quick] [--json OUT]`` runs every hostile certification target (``hostile.py``) and every
malformed file against every command that reads it (``files.py``), each in its own process with a
hard outer timeout, and prints the table

| category | inputs | clear error | correct | silent | hang | crash | mutated | lost |

(``mutated``: processes left behind by a certification run). Zeros are expected in the last six
columns. The adversarial tests run a sample of the same cases.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import files  # noqa: E402 - run as a script: the folder is on sys.path
import hostile  # noqa: E402

COLUMNS = ("clear error", "correct", "silent", "hang", "crash", "mutated", "lost")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="files only (no certification runs)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--budget", type=float, default=30.0)
    a = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="tstarg-probe-") as tmp:
        tmp = Path(tmp)
        inputs = files.make_inputs(tmp / "inputs")
        for name, path in inputs.items():
            for cmd_name, cmd in files.commands(path, tmp / f"w_{name}").items():
                (tmp / f"w_{name}").mkdir(exist_ok=True)
                outcome, detail = files.run_file_case(cmd, tmp / f"w_{name}")
                import shutil

                shutil.rmtree(tmp / f"w_{name}" / "out", ignore_errors=True)
                rows.append((f"files: {cmd_name}", name, outcome, detail))
                print(f"{cmd_name:20s} {name:16s} {outcome:12s} {detail}", flush=True)
        if not a.quick:
            for name in hostile.MODULES:
                o = hostile.run_case(name, tmp / "certify", budget=a.budget)
                rows.append(
                    (o.category, name, o.outcome, f"exit {o.code}, {o.seconds:.0f} s: {o.detail}")
                )
                print(f"{o.category:20s} {name:28s} {o.outcome:12s} {rows[-1][3]}", flush=True)
            for name in hostile.PROGRAMS:
                o = hostile.run_case(name, tmp / "certify", budget=a.budget, kind="program")
                rows.append(
                    (o.category, name, o.outcome, f"exit {o.code}, {o.seconds:.0f} s: {o.detail}")
                )
                print(f"{o.category:20s} {name:28s} {o.outcome:12s} {rows[-1][3]}", flush=True)
    table = collections.defaultdict(collections.Counter)
    for cat, _, outcome, _ in rows:
        table[cat][outcome] += 1
    print("\n| category | inputs | " + " | ".join(COLUMNS) + " |")
    print("|---|---:|" + "---:|" * len(COLUMNS))
    for cat, cnt in table.items():
        print(f"| {cat} | {sum(cnt.values())} | " + " | ".join(str(cnt[c]) for c in COLUMNS) + " |")
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    bad = sum(cnt[c] for cnt in table.values() for c in COLUMNS[2:])
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
