"""The lane-batched run of the compiled full state (:mod:`refimpl._full_state`): ``W`` trajectories at once.

:func:`run` integrates the rows of a batch with the kernel of :func:`refimpl.codegen.full_state_batch.
batch_source` -- the single-trajectory recurrence of :mod:`refimpl._full_state` with the trajectories
in SIMD lanes -- and returns what :meth:`refimpl._full_state.FullState.run` returns: the end states
and, per trajectory, its step count (negative: its failure status). Each lane runs its own
Jorba-Zou control, so a trajectory takes the steps it takes alone and keeps its own error estimate
under the two-run control of :func:`refimpl._full_state.full_state_flow`; a lane that fails (status
``-1`` non-finite, ``-3`` step budget, ``-4`` no positive step) is reported in its own row and never
changes another lane's arithmetic.

Vectorisation
    The kernel's statements run in short loops over the lanes of a C-contiguous ``V[k, row, lane]``;
    LLVM unrolls them and its SLP vectoriser packs the lanes into SIMD instructions. numba leaves that
    pass off by default (``NUMBA_SLP_VECTORIZE=0``, for compile time), so :func:`kernel` compiles the
    batch kernel -- and only it -- with the pass on, under numba's compiler lock. The pass does not
    reassociate (no ``fastmath`` beyond ``contract``, as in every Taylor kernel here): a lane's
    arithmetic is the single kernel's, each Cauchy product summed in the order ``a = 0..k``; the
    packed code may contract a different subset of multiply-adds into FMAs (one rounding each way).
"""

from __future__ import annotations

import numpy as np

from .codegen import import_source
from .codegen.full_state_batch import GROUP, LANES, batch_numbers, batch_source

__all__ = ["LANES", "MAX_SIZE", "applies", "kernel", "run"]

MAX_SIZE = 240
"""The largest structure given the lane kernel, counted as general Cauchy products plus the terms of
the derived and state rows (the statements of the generated recurrence). Its cold compilation grows
with that count -- measured at load average ~7, one run each: se(3) (117) 5.4 s, so(4) (162) 7.4 s,
su(3) (365) 13.9 s -- and a first call's time budget (refimpl._validate.TIME_BUDGET_S) counts it, so a
larger structure keeps the single-trajectory generated kernel (about 4.6 s to compile on su(3))."""


def applies(fs) -> bool:
    """Whether the structure of ``fs`` is small enough for the lane kernel (:data:`MAX_SIZE`)."""
    tb = fs.tables()
    return int((tb[7] == 0).sum()) + len(tb[3]) + len(tb[10]) + len(tb[13]) <= MAX_SIZE


_SIG = (
    "(float64[:, ::1], float64, float64, int64, int64, float64[::1], int64[::1], int64[::1], "
    "float64[:, ::1], int64[::1])"
)


def kernel(fs):
    """``(adaptive_batch, c, vrow, srow)`` for the structure of ``fs`` (kept on ``fs``): the module is
    imported from the kernel cache (:func:`refimpl.codegen.import_source`) and its one signature
    compiled with LLVM's SLP vectoriser on (or loaded from numba's disk cache)."""
    kb = fs.__dict__.get("_batch_kernel")
    if kb is not None:
        return kb
    tables = fs.tables()
    mod = import_source(batch_source(tables, fs.d, LANES, GROUP), "fsbatch_")
    fn = mod.adaptive_batch
    if not fn.signatures:
        from numba.core import config
        from numba.core.compiler_lock import global_compiler_lock

        with global_compiler_lock:  # no other compilation sees the flag
            old = config.SLP_VECTORIZE
            config.SLP_VECTORIZE = 1
            try:
                fn.compile(_SIG)
            finally:
                config.SLP_VECTORIZE = old
    kb = (fn, batch_numbers(tables), tables[8], tables[16])
    fs.__dict__["_batch_kernel"] = kb
    return kb


def run(fs, y0, T: float, tol: float, P: int, max_steps: int):
    """``(y(T), steps)`` for the rows of ``y0`` (N, d) at the local tolerance ``tol`` and order ``P``,
    ``W`` rows at a time (``y0`` is only read)."""
    fn, c, vrow, srow = kernel(fs)
    y = np.ascontiguousarray(y0, dtype=float)
    out = np.empty_like(y)
    steps = np.zeros(y.shape[0], dtype=np.int64)
    fn(y, float(T), float(tol), int(P), int(max_steps), c, vrow, srow, out, steps)
    return out, steps
