"""``tstarg certify module:object`` (or ``--cmd "PROGRAM ARGS"``): certify an implementation.

Writes ``certificate.json`` and ``certificate.md`` into ``--out`` and exits 0 only when
every applicable check passes. See :mod:`reports.certification` for the battery.

The check ids run in parallel over local processes by default (each worker loads the
target itself, or starts its own copy of the ``--cmd`` program); ``--workers 1`` runs them
in this process, ``--scheduler ADDRESS`` on a Dask cluster. Results do not depend on where
they ran (same seeds, merged in a fixed order).
"""

from __future__ import annotations

import sys

from ._parallel import add_parallel_arguments, describe, parallel_options

HELP = "certify an implementation (module:object or --cmd PROGRAM) against the reference"
PROFILES = {"dev": 8, "ci": 15, "thorough": 100}


def add_arguments(p) -> None:
    p.add_argument("target", nargs="?", help="module:object implementing the protocol (DESIGN.md)")
    p.add_argument("--cmd", help='an external program speaking JSON lines, e.g. --cmd "julia impl.jl"')
    p.add_argument("--timeout", type=float, default=10.0, help="seconds per request for --cmd (a hang after that)")
    p.add_argument("--profile", choices=sorted(PROFILES), default="ci")
    p.add_argument("--max-examples", type=int, default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--skips-file", help="check ids to skip, one per line, optional reason after a space")
    p.add_argument("--xfails-file", help="check ids expected to fail, one per line")
    p.add_argument("--out", default="reports/latest/certificate")
    add_parallel_arguments(p)


def main(args) -> int:
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
    from .certification import _materialize, _read_ids, certify, certify_parallel, write_certificate

    if bool(args.target) == bool(args.cmd):
        print("tstarg certify: give exactly one of module:object or --cmd", file=sys.stderr)
        return 2
    par = parallel_options(args)
    spec = {"cmd": args.cmd, "timeout": args.timeout} if args.cmd else args.target
    target = f"--cmd {args.cmd!r}" if args.cmd else args.target
    n = args.max_examples or PROFILES[args.profile]
    print(f"tstarg certify {target}: {n} examples per check, seed {args.seed}; {describe(**par)}; "
          f"BLAS pinned to 1 thread", flush=True)
    kw = dict(max_examples=n, seed=args.seed, skips=_read_ids(args.skips_file, "skips"),
              xfails=_read_ids(args.xfails_file, "xfails"), target=target)
    if par["workers"] == 1 and par["scheduler"] is None:
        impl = _materialize(spec)
        try:
            cert = certify(impl, **kw)
        finally:
            if hasattr(impl, "close"):
                impl.close()
    else:
        cert = certify_parallel(spec, **par, **kw)
    cert.command = "tstarg " + " ".join(sys.argv[2:]) if len(sys.argv) > 2 else cert.command
    out = write_certificate(cert, args.out)
    print(cert.summary())
    print(f"certificate: {out / 'certificate.md'}")
    return 0 if cert.passed else 1
