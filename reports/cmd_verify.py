"""``tstarg verify``: the main job -- run the checks, print a summary table, write a report.

The checks come from *providers*: ``"module:function"`` names of callables
``(max_examples, seed) -> list[CheckResult]`` (:data:`reports._verify.PROVIDERS`; ``--provider`` picks
a subset). A default provider whose module does not exist (another issue not merged yet)
is listed as skipped in the report; a requested one that is missing, or a provider that
raises, is a failed check.

Writes ``report.json`` (every check with its metrics, the environment, versions,
seed, profile, providers) and ``report.md`` into the output folder (default
``reports/latest``).

Regression check: the run is compared with the committed baseline
(``reports/baseline/report.json``, or ``--baseline PATH``; ``--no-baseline`` skips it) by
:mod:`reports.regression`. Two more rows, ``regression.accuracy`` (digits lost beyond
``--digits-slack``) and ``regression.speed`` (a speed-up of :mod:`reports.speed_checks`
fallen by more than ``--speed-factor``), fail the run like any other check; the comparison
table and its figure go into ``compare.md`` and ``figures/compare.png`` and are linked
from ``report.md``. ``--write-baseline`` stores this run as the new baseline. Progress on stdout: a bar redrawn per example on a terminal, one
line per finished check otherwise (``--quiet`` silences it). Exit status 1 when any
check fails. Profiles set the Hypothesis budget per check (:data:`properties.profiles.PROFILES`); providers
give the mpmath-driven checks a fraction of it.

This module parses the arguments; the work is done by :mod:`reports._verify` (imported by
:func:`main` only, so that ``tstarg --help`` does not load numpy, Hypothesis and the kernels).
"""

from __future__ import annotations

from tstarg.properties.profiles import PROFILES  # the profile names (light: no numpy)

HELP = "run the verification suite and write a report (the main job)"


def add_arguments(v) -> None:
    v.add_argument("--profile", choices=sorted(PROFILES), default="ci")
    v.add_argument(
        "--max-examples",
        type=int,
        default=None,
        help="Hypothesis examples per check (overrides the profile)",
    )
    v.add_argument("--seed", type=int, default=0, help="Hypothesis seed (reproducible runs)")
    v.add_argument(
        "--out", default="reports/latest", help="output folder for report.json and report.md"
    )
    v.add_argument(
        "--provider",
        action="append",
        default=None,
        metavar="MODULE:FUNCTION",
        help="run only these check providers (repeatable; default: every provider of reports._verify.PROVIDERS)",
    )
    v.add_argument("--quiet", action="store_true", help="no progress output")
    v.add_argument(
        "--baseline",
        default=None,
        metavar="REPORT",
        help="baseline report.json (or run folder) to compare with (default: reports/baseline/report.json)",
    )
    v.add_argument("--no-baseline", action="store_true", help="do not compare with a baseline")
    v.add_argument(
        "--digits-slack",
        type=float,
        default=None,
        help="digits a check may lose before it is a regression (default 2)",
    )
    v.add_argument(
        "--speed-factor",
        type=float,
        default=None,
        help="slowdown factor of a speed-up that is a regression (default 2)",
    )
    v.add_argument(
        "--write-baseline",
        action="store_true",
        help="also store this run as the committed baseline",
    )
    for name, what in (
        ("example", "one example"),
        ("check", "one check"),
        ("shrink", "shrinking a failure"),
        ("run", "the whole run"),
    ):
        v.add_argument(
            f"--{name}-seconds",
            type=float,
            default=None,
            help=f"wall-clock budget of {what} (default: the profile's, reports._verify.BUDGETS)",
        )


def main(args) -> int:
    from . import _verify  # the worker: the checks, numpy, Hypothesis (not needed by --help)

    return _verify.main(args)
