"""``tstarg stress``: numerical stability sweeps of the fast implementation, judged by the mpmath reference.

Sweeps (see :mod:`reports._stress`): toward the degenerate set (su(2), Bianchi VI_h,
su(3)), large momenta, ill-conditioned changes of basis, large Upsilon, the heavy top's
vector field toward C1 = 0, and a long integration compared with Brouwer's law.
Each point goes through :mod:`refimpl.escalate` at ``--tol`` and is classified
ok / escalated / flagged / SILENT FAILURE. The command exits 1 when any point is a
silent failure, any error bound is violated or the judge's two precisions disagree.
Writes ``report.json``, ``report.md`` and PNG figures under ``--out``.

This module parses the arguments; the work is done by :mod:`reports._stress_run` (imported by
:func:`main` only, so that ``tstarg --help`` does not load numpy, mpmath and the kernels).
"""

from __future__ import annotations

from . import _progress
from ._parallel import add_parallel_arguments

DEFAULT_IMPLEMENTATION = "tstarg.refimpl.fast:implementation"
"""The implementation under stress unless ``--implementation`` names another."""
HELP = "numerical stability sweeps: digits lost vs the error model, flagged/escalated points, Brouwer's law"


DEFAULT_OUT = "reports/stress/latest"


def add_arguments(parser) -> None:
    parser.add_argument(
        "--out", default=DEFAULT_OUT, help=f"output folder (default: {DEFAULT_OUT})"
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="a few points per sweep and a short integration (seconds)",
    )
    parser.add_argument(
        "--tol",
        type=float,
        default=1e-10,
        help="requested tolerance, relative: error <= tol * max(1, max|P|) (default 1e-10)",
    )
    parser.add_argument(
        "--no-escalate",
        action="store_true",
        help="flag points whose bound exceeds the tolerance instead of escalating them to mpmath",
    )
    parser.add_argument(
        "--judge-dps",
        type=int,
        default=50,
        help="digits of the judging reference (it also runs at +20 digits; default 50)",
    )
    parser.add_argument(
        "--implementation",
        default=DEFAULT_IMPLEMENTATION,
        metavar="MODULE:OBJECT",
        help="the fast implementation under stress (needs poisson_batch / vector_field_batch)",
    )
    parser.add_argument(
        "--sweeps", default=None, help="comma-separated subset of sweeps (and/or 'brouwer')"
    )
    parser.add_argument(
        "--brouwer-time",
        type=float,
        default=None,
        help="length of the long integration (default 1e4; 100 with --quick)",
    )
    parser.add_argument(
        "--brouwer-trajectories",
        type=int,
        default=None,
        help="ensemble size of the long integration (default 128; 16 with --quick)",
    )
    add_parallel_arguments(parser)
    _progress.add_quiet_argument(parser)


def main(args) -> int:
    from . import _stress_run  # the worker: the sweeps, numpy, mpmath (not needed by --help)

    return _stress_run.main(args)
