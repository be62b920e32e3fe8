"""The worker of ``tstarg certify`` (:mod:`reports.cmd_certify` parses the arguments and calls
:func:`main`): the harness that supervises the battery and writes the certificate."""

from __future__ import annotations

import math
import os
import shlex
import shutil
import sys
import time
from pathlib import Path

from threadpoolctl import threadpool_limits

from tstarg.properties import runner
from tstarg.properties.profiles import PROFILES as _PROFILES
from tstarg.properties.runner import CheckResult

from ._atomic import claim_output, write_text
from ._certdoc import certificate_document, write_certificate_files
from ._guard import NotAnImplementation, materialize
from ._parallel import TaskError, describe, parallel_options
from ._supervise import Died, run_supervised
from ._verify import Progress
from .certification import CHECKS, Certificate, _read_ids, certify_target
from .environment import environment
from .jsonl import ProgramFailure, check_timeout
from .regression import read_json_file

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


def _positive(name: str, v) -> float:
    if v is None or not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a positive number of seconds, got {v!r}")
    return float(v)


def _fail(msg: str) -> int:
    print(f"tstarg certify: {msg}", file=sys.stderr)
    return 2


def main(args) -> int:
    """The harness (this process) validates the arguments, locks the output folder, runs the
    target in a supervised child (:mod:`reports._supervise`: a hard wall at ``--budget``, every
    process it started killed at the end) and writes the certificate, whatever the child did."""
    t_start = time.monotonic()  # the wall counts from here, the harness's own work included
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

        skips, xfails = _read_ids(args.skips_file, "skips"), _read_ids(args.xfails_file, "xfails")

        unknown = [c for c in args.check or [] if c not in CHECKS]
        if unknown:
            raise ValueError(
                f"--check {unknown[0]!r}: unknown check id (known: {', '.join(CHECKS)})"
            )
        if args.target:
            _check_target_name(args.target)
        replay = _read_replay(args.replay) if args.replay else None
    except (ValueError, OSError) as exc:
        return _fail(str(exc))
    if replay is not None and not replay:
        print(f"--replay {args.replay}: no failing example stored; nothing to replay")
        return 0
    spec = (
        {"cmd": args.cmd, "timeout": timeout, "startup_timeout": startup}
        if args.cmd
        else args.target
    )
    target = f"--cmd {args.cmd!r}" if args.cmd else args.target
    n = args.max_examples or PROFILES[args.profile]
    job = {
        "spec": spec,
        "target": target,
        "par": par,
        "budget": budget,
        "run_budget": run_budget,
        "replay": replay,
        "seed": args.seed,
        "kw": {
            "max_examples": n,
            "seed": args.seed,
            "skips": skips,
            "xfails": xfails,
            "target": target,
            "checks": args.check,
            **({"shrink": False} if getattr(args, "verdict_only", False) else {}),
        },
    }
    if replay is not None:
        return _replay_result(run_supervised(CHILD, job, wall=run_budget), run_budget)
    # the part of the budget left for the child (its checks stop drawing before the wall)
    job["run_budget"] = wall = max(1.0, run_budget - (time.monotonic() - t_start))
    try:
        out = claim_output(args.out)
    except (OSError, RuntimeError) as exc:
        return _fail(f"--out {args.out}: {exc}")
    stderr_dir = None
    if args.cmd:
        stderr_dir = out / "program-stderr.parts"
        shutil.rmtree(stderr_dir, ignore_errors=True)
        stderr_dir.mkdir(parents=True, exist_ok=True)
        job["spec"] = dict(spec, stderr_dir=str(stderr_dir))
    result = run_supervised(CHILD, job, wall=wall)
    if isinstance(result, dict) and result.get("kind") == "error":
        if stderr_dir is not None:
            shutil.rmtree(stderr_dir, ignore_errors=True)
        return _fail(result["message"])
    cert = (
        result["cert"]
        if isinstance(result, dict) and result.get("kind") == "cert"
        else _broken_certificate(
            target, args.seed, n, result.reason if isinstance(result, Died) else str(result)
        )
    )
    cert.command = (  # argv[1] is the subcommand ("certify"): the line as typed
        "tstarg " + " ".join(shlex.quote(a) for a in sys.argv[1:])
        if len(sys.argv) > 2
        else cert.command
    )
    _require_a_run(cert)
    replay_cmd = (
        f"tstarg certify {shlex.quote(args.target) if args.target else '--cmd ' + shlex.quote(args.cmd)} "
        f"--replay {shlex.quote(str(out / 'certificate.json'))}"
    )
    for c in cert.checks:
        if not c.passed and "example" in c.extra:
            c.extra["example"]["replay"] = replay_cmd
    env = result.get("environment") if isinstance(result, dict) else None
    doc = certificate_document(
        cert,
        environment=env or environment(),
        target=target,
        cmd=args.cmd,
        pythonpath=_pythonpath(),
        cwd=os.getcwd(),
        out=out,
    )
    tail = ""
    if stderr_dir is not None:
        _merge_stderr(stderr_dir, out / "program-stderr.log")
        tail = _incident_tails(cert)
    write_certificate_files(cert, doc, out, tail)
    print(cert.summary())
    for c in cert.checks:
        if not c.passed and c.falsifying_example:
            print(f"\n{c.name}:\n{c.falsifying_example}")
    if any(not c.passed and "example" in c.extra for c in cert.checks):
        print(f"\nreplay the failing examples: {replay_cmd}")
    print(f"certificate: {out / 'certificate.md'}")
    return 0 if cert.passed else 1


CHILD = "tstarg.reports._certify:_child"
"""The function the supervised child runs (:func:`reports._supervise.run_supervised`)."""


def _check_target_name(name: str) -> None:
    """A module target is a dotted module name (``module`` or ``module:object``), never a path."""
    mod, _, obj = name.partition(":")
    ok = all(part.isidentifier() for part in mod.split(".")) and (
        not obj or all(part.isidentifier() for part in obj.split("."))
    )
    if not ok or name.count(":") > 1:
        hint = " (a path: put its folder on PYTHONPATH and name the module)" if "/" in name else ""
        raise ValueError(
            f"target {name!r} is not 'module' or 'module:object' with dotted Python names{hint}"
        )


def _child(job: dict):
    """In the supervised child: load the target (the pre-flight: a clear error before any worker
    starts), then run the battery or the replay. Returns ``{"kind": "error"|"cert"|"replay", ...}``."""

    threadpool_limits(1)
    spec, target, budget, run_budget = job["spec"], job["target"], job["budget"], job["run_budget"]
    try:
        impl = materialize(spec, call_timeout=budget["call_timeout"])
    except (NotAnImplementation, ProgramFailure, ImportError, ValueError, OSError) as exc:
        return {"kind": "error", "message": f"cannot certify {target}: {type(exc).__name__}: {exc}"}
    provided = impl.provided
    impl.close()
    # the checks stop drawing before the hard wall, so that the run can still hand back its results
    budget["deadline"] = time.time() + max(
        0.5 * run_budget, run_budget - min(30.0, 0.2 * run_budget)
    )
    if job["replay"] is not None:
        return {"kind": "replay", "exit": _replay(job["replay"], spec, target, budget, job["seed"])}
    par, kw = job["par"], job["kw"]
    print(
        f"tstarg certify {target}: {kw['max_examples']} examples per check, seed {kw['seed']}; "
        f"{describe(**par)} (supervised); provides {', '.join(provided)}; per call "
        f"{budget['call_timeout']:g} s, per example {budget['example_seconds']:g} s, per check "
        f"{budget['check_seconds']:g} s, run budget {run_budget:g} s (a hard wall); BLAS pinned to 1 thread",
        flush=True,
    )
    cert = _run(spec, par, budget, dict(kw, provided=provided))
    if isinstance(cert, str):
        return {"kind": "broken", "message": cert}
    return {"kind": "cert", "cert": cert, "environment": environment()}


def _broken_certificate(target: str, seed, n: int, reason: str):
    """A failed certificate for a run that handed back no result."""

    cert = Certificate(
        implementation=target, version="unknown", target=target, seed=seed, max_examples=n
    )
    cert.checks.append(
        CheckResult(
            name="harness.run",
            equations="-",
            passed=False,
            worst_ratio=math.inf,
            detail=f"nothing certified: {reason}",
        )
    )
    return cert


def _run(spec, par, budget, kw):
    """The battery (in the supervised child); a broken run returns its reason as a string."""

    try:
        if par["workers"] == 1 and par["scheduler"] is None:
            with runner.listening(Progress()):
                return certify_target(spec, workers=1, budget=budget, **kw)
        return certify_target(spec, **par, budget=budget, **kw)
    except TaskError as exc:
        return f"a worker failed on check task {exc.index}: {exc.text[-3000:]}"
    except Exception as exc:  # noqa: BLE001 - a broken run is a failure with its reason, never a pass
        return f"the run broke ({type(exc).__name__}: {exc})"


def _require_a_run(cert) -> None:
    """A certificate in which no check ran a single example certifies nothing: it fails."""

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
    chunks = []
    for part in sorted(parts.glob("*.log")):
        text = part.read_text(encoding="utf-8", errors="replace")
        chunks.append(f"===== program stderr while running {part.stem} =====\n{text}")
        if text and not text.endswith("\n"):
            chunks.append("\n")
    write_text(log, "".join(chunks))
    shutil.rmtree(parts, ignore_errors=True)


def _incident_tails(cert) -> str:
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
    return "\n".join(lines) + "\n"


def _pythonpath() -> list[str]:
    """What the target's import needs: the current folder (imported first, as ``python -m``
    does) and the ``PYTHONPATH`` of this run."""
    extra = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    return [os.getcwd(), *(str(Path(p).resolve()) for p in extra)]


def _read_replay(path: str) -> dict:
    """The failing examples stored in a certificate (read in the harness, before anything runs)."""

    try:
        data = read_json_file(path, what="--replay")
        if not {"implementation", "target", "checks"} <= set(data):
            raise KeyError("a certificate has 'implementation', 'target' and 'checks'")
        checks = data["checks"]
        if not isinstance(checks, list) or not all(
            isinstance(c, dict)
            and isinstance(c.get("name"), str)
            and isinstance(c.get("passed"), bool)
            for c in checks
        ):
            raise TypeError(
                "'checks' must be a list of objects with a string name and a boolean passed"
            )
        examples = {
            c["name"]: runner.decode(c["extra"]["example"]["values"])
            for c in data.get("checks", [])
            if not c.get("passed", True) and "example" in c.get("extra", {})
        }
    except (KeyError, TypeError, AttributeError) as exc:
        raise ValueError(
            f"--replay {path}: not a certificate with stored examples ({type(exc).__name__}: {exc})"
        ) from None
    return examples


def _replay_result(result, wall: float) -> int:
    if isinstance(result, dict) and result.get("kind") == "replay":
        return int(result["exit"])
    if isinstance(result, dict) and result.get("kind") == "error":
        return _fail(result["message"])
    reason = result.reason if isinstance(result, Died) else str(result)
    print(f"tstarg certify --replay: FAIL: {reason}", file=sys.stderr)
    return 1


def _replay(examples: dict, spec, target, budget, seed) -> int:
    ids = sorted({name.split("[", 1)[0] for name in examples})
    with runner.replaying(examples):
        cert = certify_target(
            spec,
            workers=1,
            budget=budget,
            checks=ids,
            max_examples=1,
            seed=seed,
            target=target,
        )
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
