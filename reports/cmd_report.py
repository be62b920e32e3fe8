"""``tstarg report``: render a verification run, or compare two.

* ``tstarg report RUN`` re-renders ``RUN/report.md`` from ``RUN/report.json``;
* ``tstarg report --compare A B`` compares run B with run A (folders or report.json files)
  as :mod:`reports.regression` does for ``tstarg verify``: digits lost per check, speed-ups
  fallen, verdicts changed. It prints the table, writes ``compare.md`` and
  ``figures/compare.png`` into ``--out`` (default ``reports/latest/compare``) and exits 1
  when B regressed against A, 0 otherwise (like ``diff``, usable in scripts).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ._atomic import claim_output, write_text

HELP = "render a verification report, or compare two runs (--compare A B)"


def add_arguments(p) -> None:
    p.add_argument("run", nargs="?", help="a run folder (or report.json) to re-render")
    p.add_argument("--compare", nargs=2, metavar=("A", "B"), help="compare run B with run A")
    p.add_argument(
        "--out",
        default=None,
        help="output folder for compare.md (default reports/latest/compare), or for the re-rendered "
        "report.md (default: the run's folder; never the committed baseline's)",
    )
    p.add_argument(
        "--digits-slack", type=float, default=None, help="digits a check may lose (default 2)"
    )
    p.add_argument(
        "--speed-factor",
        type=float,
        default=None,
        help="allowed slowdown of a speed-up (default 2)",
    )


def main(args) -> int:
    from . import regression
    from .cmd_verify import render_markdown

    if bool(args.run) == bool(args.compare):
        print("tstarg report: give a run folder, or --compare A B", file=sys.stderr)
        return 2
    try:
        if args.run:
            rep = regression.load_report(args.run)
        else:
            a, b = (regression.load_report(x) for x in args.compare)
    except (ValueError, OSError) as exc:  # corrupted or foreign report files: a clear error, exit 2
        print(f"tstarg report: {exc}", file=sys.stderr)
        return 2
    if args.run:
        # re-rendering writes only into --out (default: the run's own folder, unless that is the
        # committed baseline, whose folder holds report.json alone: then nothing is written there)
        folder = Path(rep.pop("_path")).parent
        try:
            md = render_markdown(rep)
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            print(
                f"tstarg report: {folder}: not a complete tstarg verify report ({type(exc).__name__}: {exc})",
                file=sys.stderr,
            )
            return 2
        if args.out:
            folder = Path(args.out)
        elif folder.resolve() == regression.BASELINE.parent.resolve():
            print(md)
            print(
                f"(not written: {folder} is the committed baseline; give --out FOLDER to write report.md)"
            )
            return 0
        folder = claim_output(folder)  # the lock of verify: a run writing there keeps its folder
        if rep.get("comparison"):
            regression.plot(rep["comparison"], folder / "figures" / "compare.png")
        write_text(folder / "report.md", md)
        print(f"rendered {folder / 'report.md'}")
        return 0
    slack = regression.DIGITS_SLACK if args.digits_slack is None else args.digits_slack
    factor = regression.SPEED_FACTOR if args.speed_factor is None else args.speed_factor
    cmp = regression.compare(a, b, digits_slack=slack, speed_factor=factor)
    out = claim_output(Path(args.out or "reports/latest/compare"))
    regression.plot(cmp, out / "figures" / "compare.png")
    md = regression.render_markdown(cmp, figure="figures/compare.png")
    write_text(out / "compare.md", md)
    write_text(out / "compare.json", json.dumps(cmp, indent=2, default=str))
    print(md)
    print(f"written: {out / 'compare.md'}")
    return 1 if cmp["regressed"] else 0
