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
from .codegen.full_state_batch import GROUP, LANES, batch_groups, batch_numbers, batch_source

__all__ = ["LANES", "MAX_SIZE", "applies", "kernel", "run", "size"]

MAX_SIZE = 240
"""The largest structure whose lane kernel has every Cauchy product written out, counted as general
products plus the terms of the derived and state rows (the statements of the generated recurrence);
a larger one gets the packed form (:func:`refimpl.codegen.full_state_batch.batch_source`,
``packed=True``: the products' loop is one fixed block over index tables, so the source no longer grows
with them). The cold compilation (numba's typing and lowering dominate, about linear in the
statements: twelve per written-out product) measured, one run each, CPU, load average 7-8: written
out kirchhoff_se3 (117) 6.3 s, manakov_so4 (162) 9.2-10.4 s, free_su3 (365) 19.7 s; packed
kirchhoff_se3 3.4 s, manakov_so4 4.1 s, free_su3 6.4 s. The written-out form is the faster one where it
fits (per trajectory, 1000 trajectories at 3e-14: kirchhoff_se3 37.2 against 86.0 us, manakov_so4 15.1
against 36.1 us: its groups share factor loads, the packed blocks cannot); on free_su3 the packed one
takes 51.2 us per trajectory against 67.4 us for the single-trajectory generated kernel."""


def size(fs) -> int:
    """The structure's size in the sense of :data:`MAX_SIZE`."""
    tb = fs.tables()
    return int((tb[7] == 0).sum()) + len(tb[3]) + len(tb[10]) + len(tb[13])


def applies(fs) -> bool:
    """Every structure has a lane kernel (written out up to :data:`MAX_SIZE`, packed beyond)."""
    return True


_SIG = (
    "(float64[:, ::1], float64, float64, int64, int64, float64[::1], int64[::1], int64[::1], "
    "int64[::1], int64[::1], int64[::1], float64[:, ::1], int64[::1])"
)


def kernel(fs):
    """``(adaptive_batch, c, vrow, srow, gp, gu, gw)`` for the structure of ``fs`` (kept on ``fs``),
    packed beyond :data:`MAX_SIZE`: the module is
    imported from the kernel cache (:func:`refimpl.codegen.import_source`) and its one signature
    compiled with LLVM's SLP vectoriser on (or loaded from numba's disk cache)."""
    kb = fs.__dict__.get("_batch_kernel")
    if kb is not None:
        return kb
    tables = fs.tables()
    src = batch_source(tables, fs.d, LANES, GROUP, packed=size(fs) > MAX_SIZE)
    mod = import_source(src, "fsbatch_")
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
    kb = (fn, batch_numbers(tables), tables[8], tables[16], *batch_groups(tables))
    fs.__dict__["_batch_kernel"] = kb
    return kb


def run(fs, y0, T: float, tol: float, P: int, max_steps: int):
    """``(y(T), steps)`` for the rows of ``y0`` (N, d) at the local tolerance ``tol`` and order ``P``,
    ``W`` rows at a time (``y0`` is only read)."""
    fn, c, vrow, srow, gp, gu, gw = kernel(fs)
    y = np.ascontiguousarray(y0, dtype=float)
    out = np.empty_like(y)
    steps = np.zeros(y.shape[0], dtype=np.int64)
    fn(y, float(T), float(tol), int(P), int(max_steps), c, vrow, srow, gp, gu, gw, out, steps)
    return out, steps
