"""``tstarg certify TARGET`` (``module``, ``module:object``) or ``--cmd "PROGRAM ARGS"``: certify an implementation.

Writes ``certificate.json`` and ``certificate.md`` into ``--out`` and exits 0 only on a real
certificate: every applicable check passed and at least one check ran an example. Exit 1:
a check failed, nothing ran, or the run broke; exit 2: bad arguments or a target that is
not an implementation (none of the protocol's methods, a program that cannot be started).
See :mod:`reports.certification` for the battery and :mod:`reports._guard` for the guard
between the battery and the target.

Budgets (per profile, :data:`BUDGETS`; each can be overridden): every call to the
implementation has a timeout (``--timeout``, module or program), every example a time limit
(``--example-seconds``: examples whose reference computation runs longer are drawn again and
counted), every check a budget (``--check-seconds``) and the whole run one (``--budget``).

For ``--cmd``, the program's stderr is kept in ``program-stderr.log`` beside the certificate
and its tail quoted for each incident. A failed check's minimal example is rendered by tstarg
from the drawn values (algebra, Theta, Upsilon, point, t, worst entry) and stored as data in
the JSON; ``tstarg certify TARGET --replay OUT/certificate.json`` re-runs exactly those
examples.

The check ids run in parallel over local processes by default (each worker loads the
target itself, or starts its own copy of the ``--cmd`` program); ``--workers 1`` runs them
in this process, ``--scheduler ADDRESS`` on a Dask cluster (where per-call time limits of
module targets do not apply: they need the worker's main thread).
"""

from __future__ import annotations

import json
import math
import shlex
import shutil
import sys
import time
from pathlib import Path

from tstarg.properties.profiles import PROFILES as _PROFILES

from ._parallel import TaskError, add_parallel_arguments, describe, parallel_options
from .junit import write_junit

HELP = "certify an implementation (module, module:object or --cmd PROGRAM) against the reference"
PROFILES = {name: p["certify_examples"] for name, p in _PROFILES.items()}  # properties.profiles
BUDGETS = {
    "dev": {
        "example_seconds": 30.0,
        "check_seconds": 120.0,
        "shrink_seconds": 30.0,
        "budget": 900.0,
    },
    "ci": {
        "example_seconds": 60.0,
        "check_seconds": 300.0,
        "shrink_seconds": 60.0,
        "budget": 1800.0,
    },
    "thorough": {
        "example_seconds": 120.0,
        "check_seconds": 1200.0,
        "shrink_seconds": 300.0,
        "budget": 7200.0,
    },
}
"""Seconds (wall clock) per example, per check (each regime of a check id), for shrinking a failure
(after the first failing example) and per run, by profile."""


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


def _positive(name: str, v) -> float:
    if v is None or not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a positive number of seconds, got {v!r}")
    return float(v)


def _fail(msg: str) -> int:
    print(f"tstarg certify: {msg}", file=sys.stderr)
    return 2


def main(args) -> int:
    from threadpoolctl import threadpool_limits

    from ._guard import NotAnImplementation, materialize
    from .jsonl import ProgramFailure, check_timeout

    threadpool_limits(1)
    if bool(args.target) == bool(args.cmd):
        return _fail("give exactly one of TARGET (module or module:object) or --cmd")
    try:
        timeout = check_timeout(args.timeout, "--timeout")
        startup = check_timeout(args.startup_timeout, "--startup-timeout")
        prof = BUDGETS[args.profile]
        budget = {
            "call_timeout": timeout,
            "example_seconds": _positive(
                "--example-seconds", args.example_seconds or prof["example_seconds"]
            ),
            "check_seconds": _positive(
                "--check-seconds", args.check_seconds or prof["check_seconds"]
            ),
            "shrink_seconds": _positive(
                "--shrink-seconds", args.shrink_seconds or prof["shrink_seconds"]
            ),
        }
        run_budget = _positive("--budget", args.budget or prof["budget"])
        if args.max_examples is not None and args.max_examples < 1:
            raise ValueError(f"--max-examples must be >= 1, got {args.max_examples}")
        par = parallel_options(args)
        from .certification import _read_ids

        skips, xfails = _read_ids(args.skips_file, "skips"), _read_ids(args.xfails_file, "xfails")
        from .certification import CHECKS

        unknown = [c for c in args.check or [] if c not in CHECKS]
        if unknown:
            raise ValueError(
                f"--check {unknown[0]!r}: unknown check id (known: {', '.join(CHECKS)})"
            )
    except (ValueError, OSError) as exc:
        return _fail(str(exc))
    out = Path(args.out)
    spec = (
        {"cmd": args.cmd, "timeout": timeout, "startup_timeout": startup}
        if args.cmd
        else args.target
    )
    target = f"--cmd {args.cmd!r}" if args.cmd else args.target
    # pre-flight in this process: a clear error before any worker starts
    try:
        impl = materialize(spec, call_timeout=timeout)
    except (NotAnImplementation, ProgramFailure, ImportError, ValueError, OSError) as exc:
        return _fail(f"cannot certify {target}: {type(exc).__name__}: {exc}")
    provided = impl.provided
    impl.close()
    if args.replay:
        return _replay(args, spec, target, budget)
    n = args.max_examples or PROFILES[args.profile]
    print(
        f"tstarg certify {target}: {n} examples per check, seed {args.seed}; {describe(**par)}; "
        f"provides {', '.join(provided)}; per call {timeout:g} s, per example {budget['example_seconds']:g} s, "
        f"per check {budget['check_seconds']:g} s, run budget {run_budget:g} s; BLAS pinned to 1 thread",
        flush=True,
    )
    stderr_dir = None
    if args.cmd:
        stderr_dir = out / "program-stderr.parts"
        shutil.rmtree(stderr_dir, ignore_errors=True)
        stderr_dir.mkdir(parents=True, exist_ok=True)
        spec = dict(spec, stderr_dir=str(stderr_dir))
    budget["deadline"] = time.time() + run_budget
    kw = {"max_examples": n, "seed": args.seed, "skips": skips, "xfails": xfails, "target": target}
    if getattr(args, "verdict_only", False):
        kw["shrink"] = False
    cert = _run(spec, par, budget, dict(kw, checks=args.check, provided=provided))
    if cert is None:
        return 1
    cert.command = (
        "tstarg " + " ".join(shlex.quote(a) for a in sys.argv[2:])
        if len(sys.argv) > 2
        else cert.command
    )
    _require_a_run(cert)
    replay = (
        f"tstarg certify {shlex.quote(args.target) if args.target else '--cmd ' + shlex.quote(args.cmd)} "
        f"--replay {shlex.quote(str(out / 'certificate.json'))}"
    )
    for c in cert.checks:
        if not c.passed and "example" in c.extra:
            c.extra["example"]["replay"] = replay
    from .certification import write_certificate

    write_certificate(cert, out)
    if stderr_dir is not None:
        _merge_stderr(stderr_dir, out / "program-stderr.log")
        _append_incident_tails(cert, out)
    write_junit(cert.to_json(), out / "certificate.junit.xml")
    print(cert.summary())
    for c in cert.checks:
        if not c.passed and c.falsifying_example:
            print(f"\n{c.name}:\n{c.falsifying_example}")
    if any(not c.passed and "example" in c.extra for c in cert.checks):
        print(f"\nreplay the failing examples: {replay}")
    print(f"certificate: {out / 'certificate.md'}")
    return 0 if cert.passed else 1


def _run(spec, par, budget, kw):
    from ._guard import certify_target

    try:
        if par["workers"] == 1 and par["scheduler"] is None:
            from tstarg.properties import runner

            from .cmd_verify import Progress

            runner.PROGRESS.append(Progress())
            try:
                return certify_target(spec, workers=1, budget=budget, **kw)
            finally:
                runner.PROGRESS.pop()
        return certify_target(spec, **par, budget=budget, **kw)
    except TaskError as exc:
        print(
            f"tstarg certify: a worker failed on check task {exc.index}; no certificate.\n{exc.text[-3000:]}",
            file=sys.stderr,
        )
    except Exception as exc:  # noqa: BLE001 - a broken run is a failure with its reason, never a pass
        print(
            f"tstarg certify: the run broke ({type(exc).__name__}: {exc}); no certificate",
            file=sys.stderr,
        )
    return None


def _require_a_run(cert) -> None:
    """A certificate in which no check ran a single example certifies nothing: it fails."""
    from tstarg.properties.runner import CheckResult

    if not any(c.examples > 0 for c in cert.checks):
        cert.checks.append(
            CheckResult(
                name="certificate.nonempty",
                equations="-",
                passed=False,
                worst_ratio=math.inf,
                detail="no check ran a single example (all skipped, not provided or out of budget): nothing is certified",
            )
        )


def _merge_stderr(parts: Path, log: Path) -> None:
    with open(log, "w", encoding="utf-8") as fh:
        for part in sorted(parts.glob("*.log")):
            text = part.read_text(encoding="utf-8", errors="replace")
            fh.write(f"===== program stderr while running {part.stem} =====\n{text}")
            if text and not text.endswith("\n"):
                fh.write("\n")
    shutil.rmtree(parts, ignore_errors=True)


def _append_incident_tails(cert, out: Path) -> None:
    lines = [
        "",
        "## Program stderr",
        "",
        "The program's stderr is kept in [program-stderr.log](program-stderr.log).",
    ]
    tails = [i for i in cert.incidents if i.get("stderr_tail")]
    if tails:
        lines += ["Its last lines before each incident:", ""]
        for i in tails:
            lines += [
                f"- request {i['id']} ({i['method']}), {i['kind']}:",
                "",
                "  ```",
                *[f"  {s}" for s in i["stderr_tail"]],
                "  ```",
                "",
            ]
    with open(out / "certificate.md", "a", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")


def _replay(args, spec, target, budget) -> int:
    from tstarg.properties import runner

    from ._guard import certify_target

    try:
        data = json.loads(Path(args.replay).read_text())
        examples = {
            c["name"]: runner.decode(c["extra"]["example"]["values"])
            for c in data.get("checks", [])
            if not c.get("passed", True) and "example" in c.get("extra", {})
        }
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return _fail(
            f"--replay {args.replay}: not a certificate with stored examples ({type(exc).__name__}: {exc})"
        )
    if not examples:
        print(f"--replay {args.replay}: no failing example stored; nothing to replay")
        return 0
    ids = sorted({name.split("[", 1)[0] for name in examples})
    budget["deadline"] = time.time() + 3600.0
    runner.REPLAY.update(examples)
    try:
        cert = certify_target(
            spec,
            workers=1,
            budget=budget,
            checks=ids,
            max_examples=1,
            seed=args.seed,
            target=target,
        )
    finally:
        runner.REPLAY.clear()
    bad = 0
    for c in cert.checks:
        if c.extra.get("not_replayed"):
            continue
        print(
            f"{c.name}: {'PASS' if c.passed else 'FAIL'} on the stored example"
            + ("" if c.passed else f"\n  {c.detail}")
        )
        if not c.passed:
            bad += 1
            print(c.falsifying_example)
    return 1 if bad else 0
