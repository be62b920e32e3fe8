"""The ``tstarg`` command line."""

from __future__ import annotations

import argparse
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="tstarg", description="Verification and reference oracles for omega_L on T*G.")
    sub = p.add_subparsers(dest="command", required=True)
    v = sub.add_parser("verify", help="run the verification suite and write a report (the main job)")
    v.add_argument("--profile", choices=["dev", "ci", "thorough"], default="ci")
    v.add_argument("--max-examples", type=int, default=None, help="Hypothesis examples per check (overrides the profile)")
    v.add_argument("--seed", type=int, default=0, help="Hypothesis seed (reproducible runs)")
    v.add_argument("--out", default="reports/latest", help="output folder for report.json and report.md")
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if args.command == "verify":
        from .verify import main as verify_main

        return verify_main(args)
    raise AssertionError(args.command)  # pragma: no cover


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
