"""``tstarg claims``: the paper's claims and errata -- every numbered equation, every displayed
formula (labelled or not) and every mathematical sentence.

Runs every check named by the registry (oracles.claims, data in oracles/registry/*.toml: the labels,
then the displays and sentences of the paper's index shipped with the package, oracles.paper_index), prints
the table and the coverage (items of the paper vs entries), writes ``claims.md`` (default
``reports/claims.md``), the GNH worked examples, the qutip comparisons with their measured errors,
and Bloch-sphere figures of classical and quantum trajectories (``reports/figures/bloch_*.png``).
Numbers in the file are rounded (one or two significant digits) so that a rerun writes the same
file. Exit status 1 when an observation contradicts a recorded status, or when an item of the
paper has no entry.

This module parses the arguments; the work is done by :mod:`reports._claims` (imported by
:func:`main` only, so that ``tstarg --help`` does not load the checks).
"""

from __future__ import annotations

from . import _progress

HELP = "the paper's claims and errata (every display and mathematical sentence): run the checks, write claims.md"


def add_arguments(p) -> None:
    p.add_argument(
        "--out",
        default=None,
        help="Markdown file to write (default reports/latest/claims/claims.md; with --write "
        "the committed reports/claims.md)",
    )
    p.add_argument(
        "--figures",
        default=None,
        help="folder for the Bloch-sphere figures (default beside --out; with --write the "
        "committed reports/figures)",
    )
    p.add_argument(
        "--write",
        action="store_true",
        help="rewrite the committed table reports/claims.md and reports/figures",
    )
    p.add_argument(
        "--no-quantum", action="store_true", help="skip the qutip comparisons and figures"
    )
    _progress.add_quiet_argument(p)


def main(args) -> int:
    from . import _claims  # the worker: the registries and their checks (not needed by --help)

    return _claims.main(args)
