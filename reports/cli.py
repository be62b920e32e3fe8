"""The ``tstarg`` command line.

Each subcommand is a module ``reports/<name>.py`` providing ``HELP`` (one line),
``add_arguments(parser)`` and ``main(args) -> int``; :data:`SUBCOMMANDS` lists them.
A subcommand whose module is missing is simply not offered.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from . import environment

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

SUBCOMMANDS = ("verify", "run", "claims", "certify", "bench", "stress", "report")


def _modules():
    for name in SUBCOMMANDS:
        try:
            yield name, importlib.import_module(f"tstarg.reports.cmd_{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"tstarg.reports.cmd_{name}":
                raise


def commit() -> str:
    """The git commit tstarg runs from (:func:`reports.environment.git_commit`), ``"unknown"`` when
    its files are not a git checkout of the project (an installed wheel)."""
    return environment.git_commit() or "unknown"


def version_line() -> str:
    """``tstarg --version``: the version (pyproject.toml, through the installed metadata) and
    the commit."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        v = version("tstarg")  # what tstarg.refimpl.__version__ reads, without importing numpy
    except PackageNotFoundError:
        v = "unknown"
    return f"tstarg {v} (commit {commit()})"


class _Version(argparse.Action):
    """``--version``: computed only when asked (the commit needs git)."""

    def __init__(
        self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None
    ):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(version_line())
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="tstarg", description="Verification and reference oracles for omega_L on T*G."
    )
    p.add_argument(
        "--version", action=_Version, help="print the version and the git commit, then exit"
    )
    sub = p.add_subparsers(dest="command", required=True)
    for name, mod in _modules():
        sp = sub.add_parser(name, help=mod.HELP)
        mod.add_arguments(sp)
        sp.set_defaults(_main=mod.main)
    return p


def main(argv=None) -> int:
    if list(sys.argv[1:] if argv is None else argv) == ["--version"]:
        print(version_line())  # without importing every subcommand
        return 0
    args = build_parser().parse_args(argv)
    return int(args._main(args) or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
