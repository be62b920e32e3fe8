"""``tstarg report``: render a verification run, or compare two.

* ``tstarg report RUN`` re-renders ``RUN/report.md`` from ``RUN/report.json``;
* ``tstarg report --compare A B`` compares run B with run A (folders or report.json files)
  as :mod:`reports.regression` does for ``tstarg verify``: digits lost per check, speed-ups
  fallen, verdicts changed. It prints the table, writes ``compare.md`` and
  ``figures/compare.png`` into ``--out`` (default ``reports/latest/compare``) and exits 1
  when B regressed against A, 0 otherwise (like ``diff``, usable in scripts).

This module parses the arguments; the work is done by :mod:`reports._report` (imported by
:func:`main` only, so that ``tstarg --help`` does not load the regression module and numpy).
"""

from __future__ import annotations

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
    from . import _report  # the worker (not needed by --help)

    return _report.main(args)
