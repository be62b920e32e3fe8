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


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="tstarg", description="Verification and reference oracles for omega_L on T*G."
    )
    sub = p.add_subparsers(dest="command", required=True)
    for name, mod in _modules():
        sp = sub.add_parser(name, help=mod.HELP)
        mod.add_arguments(sp)
        sp.set_defaults(_main=mod.main)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    return int(args._main(args) or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
