"""Running the battery: :func:`certify` over the registry's checks, in this process or spread over
workers (:mod:`.parallel`), and the mutation kill rate."""

from __future__ import annotations

import time
from pathlib import Path

from hypothesis import Phase, settings
from hypothesis.errors import UnsatisfiedAssumption

from tstarg.properties import runner
from tstarg.properties.runner import (
    CheckResult,
    announce,
    finished,
    run_property,
)
from tstarg.refimpl.fast import implementation as fast

from .._guard import close_target, explain, load
from .._parallel import map_tasks
from ._common import _has
from .certificate import Certificate, reproduce_command
from .domain import Domain, declared_domain
from .group import declared_group, describe_group
from .registry import CHECKS, MUTANT_CHECKS, MUTATIONS, REGISTRY, missing, mutant


def load_target(spec: str):
    """``"package.module:object"`` (object may be dotted) to the object (the one loader,
    :func:`reports._guard.load`, unguarded)."""
    return load(spec, guard=False)


def certify(
    impl,
    *,
    max_examples: int = 20,
    seed: int | None = 0,
    skips: dict | None = None,
    xfails: dict | None = None,
    target: str = "",
    checks: list[str] | None = None,
    shrink: bool = True,
    stop_on_failure: bool = False,
    announce: bool | None = None,
) -> Certificate:
    """Run every check ``impl``'s methods allow; missing methods are skipped with the reason.

    ``announce``: print the verdict (FAIL) on stdout the moment a check finds its first failing
    example, before shrinking it (``tstarg certify`` knows the verdict within a minute and then
    shrinks within its stated budget). ``None``: when run under the command line's budgets
    (:func:`properties.runner.limits` with a shrinking budget).

    ``stop_on_failure=True`` skips the remaining checks after the first failure (enough
    for a verdict); with ``shrink=False`` too, a failing check also stops at its first failing
    example.

    ``shrink=False`` reports the first failing example as found (no shrinking, no
    explanation phase): much faster when only the verdict matters (mutation tests).
    """

    previous = settings.default
    if not shrink:
        settings.register_profile(
            "_tstarg_certify_noshrink",
            parent=previous,
            phases=[Phase.explicit, Phase.reuse, Phase.generate, Phase.target],
        )
        settings.load_profile("_tstarg_certify_noshrink")
    try:
        return _certify(
            impl,
            max_examples=max_examples,
            seed=seed,
            skips=skips,
            xfails=xfails,
            target=target,
            checks=checks,
            stop_on_failure=stop_on_failure,
            shrink=shrink,
            announce=runner.current().limits.shrink_seconds is not None
            if announce is None
            else announce,
        )
    finally:
        if not shrink:
            settings.register_profile("_tstarg_certify_restore", parent=previous)
            settings.load_profile("_tstarg_certify_restore")


def _applicable(impl, cid: str, dom: Domain) -> str | None:
    """Why check ``cid`` does not apply to ``impl`` (None: it applies): a method it needs is
    missing, or the check's own condition (:attr:`Check.applies`)."""
    check = REGISTRY[cid]
    why = check.missing([m for m in check.needs if _has(impl, m)])
    if why is None and check.applies is not None:
        why = check.applies(impl, dom)
    return why


def _note_stats(cert, cid: str, stats: dict, dom) -> None:
    for k, v in stats.items():
        if k in ("refusal message", "negative t judged"):
            continue
        cert.notes.append(f"{cid}: {k}: {v}")
    if stats.get("negative t judged"):
        cert.notes.append(
            f"{cid}: flow at negative times judged on {stats['negative t judged']} example"
            + ("s" if stats["negative t judged"] != 1 else "")
            + (" (negative_t declared: a refusal fails)" if dom.negative_t else "")
        )
    if "negative t refused (ValueError)" in stats and not any("t < 0" in n for n in cert.notes):
        cert.notes.append(
            f"flow at t < 0 refused by the implementation (ValueError: "
            f"{stats.get('refusal message', '')}): negative times are not certified"
        )


def _announcing(body, name: str, t0: float, announce: bool, shrink: bool = True):
    """``body``, printing the verdict when it first fails (an exception or a ratio above 1): one
    line per failing check, the first of them is the verdict; what follows it is said as it will
    happen (``shrink=False``, ``--verdict-only``: the example as found, no shrinking)."""
    if not announce:
        return body
    said: list[bool] = []

    def say():
        if said:
            return
        said.append(True)
        found = (
            f"tstarg certify: verdict FAIL: {name} found a failing example after "
            f"{time.perf_counter() - t0:.1f} s"
        )
        if not shrink:
            print(found + "; the certificate shows it as found (not shrunk)", flush=True)
            return
        budget = runner.current().limits.shrink_seconds
        print(
            found
            + "; shrinking it"
            + (f" (at most {budget:g} s)" if budget is not None else "")
            + ", then the certificate with the smallest failing example found",
            flush=True,
        )

    def wrapped(example):
        try:
            out = body(example)
        except UnsatisfiedAssumption:
            raise  # reject(): drawn again, not a failure
        except Exception:
            say()
            raise
        if out is not None and not float(out[0]) <= 1.0:
            say()
        return out

    return wrapped


def _minimality(res, shrink: bool) -> str:
    if not shrink:
        return "not shrunk (shrink=False, --verdict-only): the first failing example found"
    if "shrinking stopped" in (res.detail or ""):
        return "not minimal: shrinking stopped at its time budget (the smallest found by then)"
    if res.extra.get("replayed"):
        return "the stored example, replayed"
    return "minimal: shrunk by Hypothesis until no smaller example failed"


def _certify(
    impl,
    *,
    max_examples,
    seed,
    skips,
    xfails,
    target,
    checks,
    stop_on_failure=False,
    shrink=True,
    announce=False,
) -> Certificate:
    t0 = time.perf_counter()
    dom = declared_domain(impl)
    cert = Certificate(
        implementation=str(getattr(impl, "name", type(impl).__name__)),
        version=str(getattr(impl, "version", "unknown")),
        target=target or repr(impl),
        seed=seed,
        max_examples=max_examples,
        xfailed=dict(xfails or {}),
        command=reproduce_command(target, seed, max_examples),
        domain=dom.describe(),
        group=describe_group(declared_group(impl)),
    )
    skips = dict(skips or {})
    for cid, check in REGISTRY.items():
        if checks is not None and cid not in checks:
            continue
        if stop_on_failure and cert.failed:
            cert.skipped[cid] = "not run: an earlier check already failed (stop_on_failure)"
            continue
        if cid in skips:
            cert.skipped[cid] = skips[cid]
            continue
        why = _applicable(impl, cid, dom)
        if why is not None:
            cert.skipped[cid] = why
            continue
        for variant in check.plan(impl, dom):
            name = cid if variant.suffix is None else f"{cid}[{variant.suffix}]"
            if variant.skip is not None:
                cert.skipped[name] = variant.skip
                continue
            stats: dict = {}
            body, strat = check.build(impl, dom, stats, **variant.kwargs)
            if body is None:
                cert.skipped[name] = strat
                continue
            res = run_property(
                name,
                variant.equations or check.equations,
                _announcing(body, name, t0, announce, shrink),
                strat,
                max_examples=variant.factor * check.budget(max_examples),
                seed=seed,
                explicit=() if check.sentinels is None else tuple(check.sentinels(impl, dom)),
            )
            res.extra.update(stats)
            if not res.passed and res.falsifying_example:
                res.extra["smallest failing example"] = _minimality(res, shrink)
            if check.extra is not None:
                res.extra.update(check.extra(impl))
            cert.checks.append(res)
            _note_stats(cert, cid, stats, dom)
            if stop_on_failure and cert.failed:
                break
    cert.incidents = list(getattr(impl, "incidents", []) or [])
    cert.seconds = time.perf_counter() - t0
    return cert


def _unit(item):
    """Worker: one check id on a freshly loaded target (guarded unless ``guard`` is False), within
    the run's budgets (none when ``budget`` is None)."""
    spec, cid, kwargs, budget, guard = item
    if isinstance(spec, dict) and spec.get("stderr_dir"):
        spec = dict(spec, stderr_log=str(Path(spec["stderr_dir"]) / f"{cid}.log"))
    if budget is None:
        impl = load(spec, guard=guard, call_timeout=None)
        try:
            return certify(impl, checks=[cid], **kwargs)
        finally:
            close_target(impl)
    impl = load(spec, guard=guard, call_timeout=budget["call_timeout"])
    left = budget["deadline"] - time.time()
    check_s = max(1e-3, min(budget["check_seconds"], left))
    try:
        with runner.limits(
            example_seconds=budget["example_seconds"],
            check_seconds=check_s,
            shrink_seconds=budget.get("shrink_seconds"),
        ):
            return certify(impl, checks=[cid], **kwargs)
    finally:
        close_target(impl)


def certify_target(
    spec,
    *,
    workers=None,
    scheduler=None,
    budget: dict | None = None,
    checks=None,
    provided=None,
    guard: bool = True,
    **kwargs,
):
    """The one run-and-merge, for in-process (``workers=1``; ``spec`` may then be an object),
    guarded and parallel runs: the battery on ``spec`` with the budgets ``{"call_timeout",
    "example_seconds", "check_seconds", "shrink_seconds", "deadline" (time.time())}`` (None: no
    limits); one unit per check id (:func:`reports._parallel.map_tasks`), merged in check order.
    Check ids listed in ``skips`` or needing a method outside ``provided`` (when given) get their
    reason without starting a unit (no program started for nothing). ``guard=False`` runs the
    battery on the bare target (no per-call limits, no input/output guard): what
    ``certification.certify_parallel`` promises, the serial result split over workers."""
    t0 = time.perf_counter()
    ids = [c for c in CHECKS if checks is None or c in checks]
    skips = dict(kwargs.get("skips") or {})
    pre = {}
    for cid in ids:
        if cid in skips:
            pre[cid] = skips[cid]
        elif provided is not None and missing(cid, provided) is not None:
            pre[cid] = missing(cid, provided)
    run_ids = [c for c in ids if c not in pre] or ids[:1]
    items = [(spec, cid, kwargs, budget, guard) for cid in run_ids]
    if (workers == 1 or len(items) == 1) and scheduler is None:
        parts = [_unit(it) for it in items]
    else:
        parts = map_tasks(_unit, items, workers=workers, scheduler=scheduler, wait=False)
    first = parts[0]
    cert = Certificate(
        implementation=first.implementation,
        version=first.version,
        target=first.target,
        seed=first.seed,
        max_examples=first.max_examples,
        xfailed=dict(kwargs.get("xfails") or {}),
        command=first.command,
        domain=first.domain,  # what was certified, and the notes on it, survive the merge
        group=first.group,
    )
    for part in parts:
        cert.checks.extend(part.checks)
        cert.skipped.update(part.skipped)
        cert.incidents.extend(part.incidents)
        cert.notes.extend(n for n in part.notes if n not in cert.notes)
    cert.skipped.update({k: v for k, v in pre.items() if k not in cert.skipped})
    cert.skipped = {k: cert.skipped[k] for k in CHECKS if k in cert.skipped}
    if guard:
        for c in cert.checks:
            explain(c)
    cert.seconds = time.perf_counter() - t0
    return cert


def certify_parallel(
    spec,
    *,
    workers: int | None = None,
    scheduler=None,
    max_examples: int = 20,
    seed: int | None = 0,
    skips: dict | None = None,
    xfails: dict | None = None,
    target: str = "",
    shrink: bool = True,
    checks: list[str] | None = None,
) -> Certificate:
    """:func:`certify` with the check ids spread over worker processes or a Dask cluster: the bare
    (unguarded) run of :func:`certify_target`, the one run-and-merge.

    ``spec`` names the target so that each worker can load it (``"module:object"``, or
    ``{"cmd": ..., "timeout": ...}`` for a JSON-lines program: one program per worker).
    Each check id runs exactly as it would serially (same seed, same examples); the
    partial certificates are merged in :data:`CHECKS` order, so the result equals the serial
    one except for timings (``tests/test_parallel.py``). ``workers=1`` without a scheduler
    runs in this process.
    """
    return certify_target(
        spec,
        workers=workers,
        scheduler=scheduler,
        guard=False,
        checks=checks,
        max_examples=max_examples,
        seed=seed,
        skips=skips,
        xfails=xfails,
        target=target,
        shrink=shrink,
    )


def certificate_checks(max_examples: int, seed: int | None = 0) -> list[CheckResult]:
    """``tstarg verify`` provider: the certificate of the fast implementation (dogfood) and the
    mutation kill rate (every mutant of :mod:`reports.mutants` must be rejected, the correct
    ``Plain`` accepted). Both at a budget of ``max(4, max_examples // 3)`` examples per check."""

    k = max(4, max_examples // 3)
    t0 = time.perf_counter()
    announce("certificate[refimpl.fast]")  # the progress display's current step
    cert = certify(fast, max_examples=k, seed=seed, target="tstarg.refimpl.fast:implementation")
    digits = [c.min_digits for c in cert.checks if c.min_digits is not None]
    res_cert = CheckResult(
        name="certificate[refimpl.fast]",
        equations="vier9, vier10, vier11",
        examples=sum(c.examples for c in cert.checks),
        worst_ratio=max((c.worst_ratio for c in cert.checks), default=0.0),
        min_digits=min(digits) if digits else None,
        passed=cert.passed,
        detail="" if cert.passed else cert.summary(),
        seconds=time.perf_counter() - t0,
        extra={"certificate": cert.to_json()},
    )
    finished(res_cert)
    t1 = time.perf_counter()
    announce("mutation_kill_rate", len(MUTATIONS) + 1)  # one step per mutant, as they arrive
    kr = kill_rate(max_examples=k, seed=seed, on_result=_kill_progress())
    res_kill = CheckResult(
        name="mutation_kill_rate",
        equations="(meta)",
        examples=len(kr["killed"]) + len(kr["survived"]),
        worst_ratio=0.0 if kr["rate"] == 1.0 and kr["correct_passes"] else float("inf"),
        passed=kr["rate"] == 1.0 and kr["correct_passes"],
        detail=f"kill rate {kr['rate']:.0%}; survivors: {kr['survived']}; correct implementation passes: {kr['correct_passes']}",
        seconds=time.perf_counter() - t1,
        extra=kr,
    )
    return [res_cert, finished(res_kill)]


def _kill_progress():
    """The progress of :func:`kill_rate` inside ``tstarg verify``: the mutants certified so far."""

    count = [0]

    def on_result(index, value):
        count[0] += 1
        runner.advance("mutation_kill_rate", count[0], len(MUTATIONS) + 1)

    return on_result


def _certify_mutant(item) -> bool:
    """Worker of :func:`kill_rate`: does the mutant ``name`` (``None``: the correct ``Plain``) pass?"""

    name, max_examples, seed = item
    # The mutants' own checks fail by design: keep them out of any progress display.
    with runner.silenced():
        cert = certify(
            mutant(name),
            max_examples=max_examples,
            seed=seed,
            checks=MUTANT_CHECKS.get(name),
            shrink=False,
            stop_on_failure=name is not None,
            announce=False,  # a mutant's FAIL is the expected outcome, not a verdict to print
        )
        return cert.passed


def kill_rate(
    *,
    max_examples: int = 8,
    seed: int | None = 0,
    workers: int | None = None,
    scheduler=None,
    on_result=None,
) -> dict:
    """Certify every mutant of :mod:`reports.mutants` (stopping at its first failed check) and the
    correct ``Plain``.

    The mutants are independent tasks of :func:`reports._parallel.map_tasks` (local processes
    by default, ``workers=1`` in this process, or a Dask ``scheduler``).
    Returns ``{"killed": [...], "survived": [...], "rate": float, "correct_passes": bool}``.
    """

    names = list(MUTATIONS) + [None]
    passed = map_tasks(
        _certify_mutant,
        [(n, max_examples, seed) for n in names],
        workers=workers,
        scheduler=scheduler,
        on_result=on_result,
    )
    verdict = dict(zip(names, passed))
    killed = [n for n in MUTATIONS if not verdict[n]]
    survived = [n for n in MUTATIONS if verdict[n]]
    return {
        "killed": killed,
        "survived": survived,
        "rate": len(killed) / len(MUTATIONS),
        "correct_passes": verdict[None],
        "mutants": dict(MUTATIONS),
    }
