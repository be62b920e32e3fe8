"""``tstarg certify TARGET`` (``module``, ``module:object``) or ``--cmd "PROGRAM ARGS"``: certify an implementation.

Writes ``certificate.json`` and ``certificate.md`` into ``--out`` and exits 0 only on a real
certificate: every applicable check passed and at least one check ran an example. Exit 1:
a check failed, nothing ran, or the run broke; exit 2: bad arguments or a target that is
not an implementation (none of the protocol's methods, a program that cannot be started).
See :mod:`reports.certification` for the battery and :mod:`reports._guard` for the guard
between the battery and the target.

Budgets (per profile, :data:`reports._certify.BUDGETS`; each can be overridden): every call to the
implementation has a timeout (``--timeout``, module or program), every example a time limit
(``--example-seconds``: examples whose reference computation runs longer are drawn again and
counted), every check a budget (``--check-seconds``) and the whole run one (``--budget``).

For ``--cmd``, the program's stderr is kept in ``program-stderr.log`` beside the certificate
and its tail quoted for each incident. A failed check's minimal example is rendered by tstarg
from the drawn values (algebra, Theta, Upsilon, point, t, worst entry) and stored as data in
the JSON; ``tstarg certify TARGET --replay OUT/certificate.json`` re-runs exactly those
examples.

The harness owns time, signals and exit codes: this process validates the arguments, locks
``--out`` (a concurrent run writes to ``--out/run-<pid>`` and says so), and runs the target in a
supervised child (:mod:`reports._supervise`) under every worker setting. ``--budget`` is a hard
wall: past it the child's whole session (workers, programs, their children) is killed. A child
that ends without a result (``os._exit``, ``sys.exit``, ``KeyboardInterrupt``, a signal, at import
or in a method) yields a FAIL certificate with the reason (check ``harness.run``), never exit 0.
The certificate (:mod:`reports._certdoc`, schema ``reports/schema/certificate.schema.json``)
carries the environment, per check the margin and the judge's own error, and per failure
copy-paste reproducers; it is written atomically.

The check ids run in parallel over local processes by default (each worker loads the
target itself, or starts its own copy of the ``--cmd`` program); ``--workers 1`` runs them
in this process, ``--scheduler ADDRESS`` on a Dask cluster (where per-call time limits of
module targets do not apply: they need the worker's main thread).

This module parses the arguments; the work is done by :mod:`reports._certify` (imported by
:func:`main` only, so that ``tstarg --help`` does not load numpy and the battery).
"""

from __future__ import annotations

from tstarg.properties.profiles import PROFILES  # the profile names (light: no numpy)

from ._parallel import add_parallel_arguments

HELP = "certify an implementation (module, module:object or --cmd PROGRAM) against the reference"


def add_arguments(p) -> None:
    p.add_argument(
        "target", nargs="?", help="module[:object] implementing the protocol (docs/design.md)"
    )
    p.add_argument(
        "--cmd", help='an external program speaking JSON lines, e.g. --cmd "julia impl.jl"'
    )
    p.add_argument(
        "--timeout",
        type=float,
        default=10.0,
        help="seconds per call to the implementation (module or program), in (0, 3600]",
    )
    p.add_argument(
        "--startup-timeout",
        type=float,
        default=30.0,
        help="--cmd: seconds the first request after a (re)start may take (program start-up), in (0, 3600]",
    )
    p.add_argument("--profile", choices=sorted(PROFILES), default="ci")
    p.add_argument("--max-examples", type=int, default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--verdict-only",
        action="store_true",
        help="stop each check at its first failing example, without shrinking it: the fastest "
        "verdict on a failing implementation (the example shown is then not minimal)",
    )
    p.add_argument(
        "--example-seconds",
        type=float,
        default=None,
        help="time limit per example (default: profile)",
    )
    p.add_argument(
        "--check-seconds", type=float, default=None, help="budget per check id (default: profile)"
    )
    p.add_argument(
        "--shrink-seconds",
        type=float,
        default=None,
        help="time for shrinking a failure to a smaller example (default: profile)",
    )
    p.add_argument(
        "--budget",
        type=float,
        default=None,
        help="budget of the whole run in seconds (default: profile)",
    )
    p.add_argument(
        "--check",
        action="append",
        default=None,
        metavar="ID",
        help="run only this check id (repeatable; default: all)",
    )
    p.add_argument(
        "--skips-file", help="check ids to skip, one per line, optional reason after a space"
    )
    p.add_argument("--xfails-file", help="check ids expected to fail, one per line")
    p.add_argument(
        "--replay",
        metavar="CERTIFICATE_JSON",
        help="re-run the failing examples stored in a certificate.json (no search), print the verdicts",
    )
    p.add_argument("--out", default="reports/latest/certificate")
    add_parallel_arguments(p)


def main(args) -> int:
    from . import _certify  # the worker: the harness and the battery (not needed by --help)

    return _certify.main(args)
