"""The worker of ``tstarg report`` (:mod:`reports.cmd_report` parses the arguments and calls
:func:`main`): render a run's report, or compare two runs."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from . import regression
from ._atomic import claim_output, write_text
from ._verify import render_markdown


def main(args) -> int:
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
