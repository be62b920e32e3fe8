"""``tstarg run SCENE``: plan a scene, integrate it, write npz + CSV + a PNG, say what was skipped.

This module parses the arguments; the work is done by :mod:`reports._run` (imported by
:func:`main` only, so that ``tstarg --help`` does not load the integrators and numpy).
"""

from __future__ import annotations

from . import _progress

HELP = "integrate a scene (TOML): prints the plan and what it skipped, writes npz, CSV and a plot"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="scene TOML file (see refimpl/scenes/)")
    parser.add_argument(
        "--out", default=None, help="output folder (default: reports/runs/<scene stem>)"
    )
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG")
    _progress.add_quiet_argument(parser)


def main(args) -> int:
    from . import _run  # the worker (not needed by --help)

    return _run.main(args)
