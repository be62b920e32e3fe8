"""Scale-out for the sweeps (certify, bench, stress): local processes by default, Dask when asked.

:func:`map_tasks` is the one entry point. It maps a picklable top-level function over a
list of picklable items and returns the results in input order, so a sweep's result does
not depend on where it ran:

* ``workers=1``: serial, in this process (what tests and debugging want);
* ``workers=None`` or ``k > 1``: a :class:`concurrent.futures.ProcessPoolExecutor` with
  ``k`` processes (default: the number of usable cores), each pinned to one BLAS thread;
* ``scheduler="tcp://host:port"``: the tasks go to a running Dask distributed scheduler
  (``dask.distributed.Client(address)``); ``scheduler="local"`` starts a
  :class:`distributed.LocalCluster` of ``workers`` processes for the duration of the call;
  a ``distributed.Client`` object is used as it is.

Tasks must be deterministic functions of their item (seeds travel inside the item): the
test ``tests/test_parallel.py`` checks that a local Dask cluster and a process pool give
the serial results (bit for bit for elementwise numpy; BLAS kernels may round the last bit
differently in another process, where memory alignment differs). A task that raises makes :func:`map_tasks` raise
:class:`TaskError` naming the task's index and item, with the original traceback text.
"""

from __future__ import annotations

import os
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any, Callable, Iterable, Sequence

from threadpoolctl import threadpool_limits

__all__ = [
    "map_tasks",
    "TaskError",
    "add_parallel_arguments",
    "parallel_options",
    "usable_cores",
    "describe",
]


class TaskError(RuntimeError):
    """A task of a sweep raised; ``index`` and ``item`` say which, ``text`` is the worker's traceback."""

    def __init__(self, index: int, item: Any, text: str):
        super().__init__(f"task {index} ({item!r:.200}) raised:\n{text}")
        self.index, self.item, self.text = index, item, text


def usable_cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _pin_blas() -> None:
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    os.environ["OMP_NUM_THREADS"] = "1"
    os.environ["MKL_NUM_THREADS"] = "1"
    try:
        threadpool_limits(1)
    except Exception:  # noqa: BLE001 - pinning is best effort in a worker
        pass


class _Guarded:
    """``fn(item)`` returning ``(True, result)`` or ``(False, traceback text)``: exceptions cross
    process boundaries as text, so an unpicklable exception cannot hang the pool."""

    def __init__(self, fn: Callable):
        self.fn = fn

    def __call__(self, item):
        _pin_blas()
        try:
            return True, self.fn(item)
        except BaseException:  # noqa: BLE001 - reported with its index by map_tasks
            return False, traceback.format_exc()


def _collect(items: Sequence, outcomes: Iterable, on_result=None) -> list:
    results = []
    for i, (ok, value) in enumerate(outcomes):
        if not ok:
            raise TaskError(i, items[i], value)
        if on_result is not None:
            on_result(i, value)
        results.append(value)
    return results


def _as_they_arrive(pool, guarded, items, on_result) -> list:
    """Submit every item; call ``on_result(index, value)`` in the order results arrive (the
    parent's progress display); return the results in the order of ``items``."""

    futures = {pool.submit(guarded, it): i for i, it in enumerate(items)}
    out: list = [None] * len(items)
    for fut in as_completed(futures):
        i = futures[fut]
        ok, value = fut.result()
        if not ok:
            raise TaskError(i, items[i], value)
        on_result(i, value)
        out[i] = value
    return out


def map_tasks(
    fn: Callable,
    items: Iterable,
    *,
    workers: int | None = None,
    scheduler: Any = None,
    on_result: Callable[[int, Any], None] | None = None,
    wait: bool = True,
) -> list:
    """``[fn(item) for item in items]``, computed serially, over local processes or on Dask.

    ``fn`` must be importable by name (a module-level function or a picklable callable
    object). Results come back in the order of ``items``. ``on_result(index, value)``, if
    given, is called in this process as each result arrives (a process pool calls it in
    completion order): the hook of a progress display (:meth:`reports._progress.Progress.callback`).
    ``wait=False``: return as soon as the results are in, without waiting for the worker processes
    to leave (code under test may keep a worker alive, e.g. with a non-daemon thread; the
    supervisor kills what is left).
    """
    items = list(items)
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be a positive integer or None, got {workers!r}")
    guarded = _Guarded(fn)
    if scheduler is not None:
        return _collect(items, _map_dask(guarded, items, scheduler, workers), on_result)
    k = min(workers or usable_cores(), max(1, len(items)))
    if k == 1:
        return _collect(items, (guarded(it) for it in items), on_result)
    _pin_blas()  # inherited by the forked workers
    pool = ProcessPoolExecutor(max_workers=k)
    try:
        if on_result is not None:
            return _as_they_arrive(pool, guarded, items, on_result)
        return _collect(items, pool.map(guarded, items))
    finally:
        pool.shutdown(wait=wait, cancel_futures=True)


def _map_dask(guarded: _Guarded, items: list, scheduler, workers: int | None) -> list:
    """The guarded outcomes ``(ok, value)`` of every item, gathered from Dask."""
    try:  # local: dask.distributed is heavy and needed only with --scheduler
        from distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover - dask is a dependency
        raise RuntimeError(
            "a Dask scheduler was given but dask.distributed is not installed"
        ) from exc
    if isinstance(scheduler, Client):
        return scheduler.gather(scheduler.map(guarded, items, pure=False))
    if not isinstance(scheduler, str) or not scheduler:
        raise ValueError(
            f"scheduler must be an address like 'tcp://host:8786', 'local' or a Client, got {scheduler!r}"
        )
    if scheduler == "local":
        n = workers or usable_cores()
        with (
            LocalCluster(
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None
            ) as cluster,
            Client(cluster) as client,
        ):
            return client.gather(client.map(guarded, items, pure=False))
    with Client(scheduler) as client:
        return client.gather(client.map(guarded, items, pure=False))


def add_parallel_arguments(parser) -> None:
    """``--workers N`` and ``--scheduler ADDRESS`` for a sweep command."""
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        help="local worker processes (default: usable cores; 1 = serial, in-process)",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run the sweep on a Dask distributed scheduler (tcp://host:port), or 'local' to "
        "start a local Dask cluster",
    )


def parallel_options(args) -> dict:
    """The keyword arguments of :func:`map_tasks` from parsed ``--workers`` / ``--scheduler``."""
    workers = getattr(args, "workers", None)
    if workers is not None and workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    return {"workers": workers, "scheduler": getattr(args, "scheduler", None)}


def describe(workers: int | None = None, scheduler: Any = None) -> str:
    """One line for a command's output: where the sweep runs."""
    if scheduler is not None:
        return f"Dask scheduler {scheduler if isinstance(scheduler, str) else 'client'}"
    k = workers or usable_cores()
    return "serial, in-process" if k == 1 else f"{k} local processes"
