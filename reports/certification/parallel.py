"""The run spread over workers, and the target loader: delegates to the one run-and-merge and the
one loader of :mod:`reports._guard` (which imports the battery's modules, never this package)."""

from __future__ import annotations

from .certificate import Certificate


def load_target(spec: str):
    """``"package.module:object"`` (object may be dotted) or ``"module"`` to the object (the one
    loader, :func:`reports._guard.load`, unguarded)."""
    from .._guard import load

    return load(spec, guard=False)


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
    """:func:`certify` with the check ids spread over worker processes or a Dask cluster: the one
    run-and-merge, :func:`reports._guard.certify_target`, on the bare target (``guard=False``).

    ``spec`` names the target so that each worker can load it (``"module:object"``, or
    ``{"cmd": ..., "timeout": ...}`` for a JSON-lines program: one program per worker).
    Each check id runs exactly as it would serially (same seed, same examples); the
    partial certificates are merged in registry order, so the result equals the serial
    one except for timings (``tests/test_parallel.py``). ``workers=1`` without a scheduler
    runs in this process.
    """
    from .._guard import certify_target

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
