"""``tstarg bench``: work-precision diagrams for flows and brackets, the protocol flow on every
algebra against heyoka, and batch throughput.

This module parses the arguments; the work is done by :mod:`reports._bench` (imported by :func:`main`
only, so that ``tstarg --help`` does not load numpy, scipy and the kernels).
"""

from __future__ import annotations

from ._parallel import add_parallel_arguments
from ._progress import add_quiet_argument

HELP = (
    "work-precision benchmarks: flows and brackets vs scipy, heyoka and the mpmath reference, "
    "the protocol flow on every algebra, batch throughput"
)


def add_arguments(p) -> None:
    p.add_argument(
        "--out",
        default="reports/bench/latest",
        help="output folder (default: reports/bench/latest)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="tiny run (t = 10, short ladders, small batches) for tests; seconds",
    )
    p.add_argument(
        "--problems",
        default=None,
        help="comma-separated flow problems (default: heavy_top,free_top; also: modified_top, "
        "Theta and Upsilon != 0; asym_heavy_top, the heavy top without a constant component; none: "
        "no su(2) flow section)",
    )
    p.add_argument(
        "--protocol-problems",
        default=None,
        help="comma-separated problems of the protocol-flow section (ours vs heyoka on the full state; "
        "default: kirchhoff_se3,manakov_so4,free_su3,bianchi_cocycle,modified_su3,heavy_top_full; "
        "--quick: bianchi_cocycle; none: skip the section)",
    )
    p.add_argument(
        "--protocol-batch",
        type=int,
        default=None,
        help="trajectories in the protocol-flow batch (default 10000; --quick 40)",
    )
    p.add_argument(
        "--reuse",
        action="append",
        default=None,
        metavar="REPORT.json",
        help="take the sections this run leaves out (e.g. --problems none --no-brackets --no-batch) "
        "from an earlier report.json, figures copied; the report names the run each came from "
        "(repeatable: the first file holding a section gives it)",
    )
    p.add_argument(
        "--methods",
        default=None,
        help="comma-separated tstarg flow methods (default: every method of METHODS that applies)",
    )
    p.add_argument(
        "--ref-dps",
        type=int,
        default=None,
        help="digits of the GBS reference (default 20; quick 16)",
    )
    p.add_argument(
        "--batch-method",
        default="taylor20",
        help="tstarg method of the batch-throughput part (default taylor20: generated scalar code up to 16 trajectories, numpy beyond)",
    )
    p.add_argument(
        "--no-brackets", action="store_true", help="skip the Poisson-tensor work-precision part"
    )
    p.add_argument("--no-batch", action="store_true", help="skip the batch-throughput part")
    p.add_argument(
        "--no-heyoka",
        action="store_true",
        help="leave out the heyoka contender (included when heyoka is importable: pip install .[bench])",
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--impl",
        default=None,
        metavar="MODULE:OBJECT",
        help="a third-party implementation of the protocol (what tstarg certify takes) on the same "
        "diagrams: its flow on each problem, its poisson_tensor on the bracket cases",
    )
    g.add_argument(
        "--cmd",
        default=None,
        metavar='"PROGRAM ARGS"',
        help="the same for a program speaking the JSON-lines protocol (docs/protocol.md)",
    )
    p.add_argument(
        "--timeout",
        type=float,
        default=600.0,
        help="with --cmd: seconds per request (default 600: a flow to t = 100 may be long)",
    )
    add_parallel_arguments(p)
    add_quiet_argument(p)


def main(args) -> int:
    from . import _bench  # the worker: numpy, scipy, the kernels (not needed by --help)

    return _bench.main(args)
