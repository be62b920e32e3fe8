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
    The order body of the recurrence is LLVM IR on vectors of ``W`` float64, one lane per trajectory
    (:func:`refimpl.codegen._full_state_ir.lanes_order_intrinsic`, over a C-contiguous ``V[k, row,
    lane]``); the rest of the kernel (step sizes, the compensated Horner update) runs in short loops
    over the lanes, which LLVM unrolls and its SLP vectoriser packs into SIMD instructions. numba
    leaves that pass off by default (``NUMBA_SLP_VECTORIZE=0``, for compile time), so :func:`kernel`
    compiles the batch kernel -- and only it -- with the pass on, under numba's compiler lock. Nothing
    reassociates (no ``fastmath`` beyond ``contract``, as in every Taylor kernel here): a lane's
    arithmetic is the single kernel's, each Cauchy product summed in the order ``a = 0..k``; the
    compiler may contract a different subset of multiply-adds into FMAs (one rounding each way).
"""

from __future__ import annotations

import math

import numpy as np

from .codegen import import_source
from .codegen._full_state_ir import packed_order
from .codegen.full_state_batch import GROUP, LANES, batch_groups, batch_numbers, batch_source

try:
    from numba import njit
except ImportError:  # pragma: no cover - the plain-Python path (as refimpl._full_state_kernel)

    def njit(*a, **kw):
        return (lambda fn: fn) if not a else a[0]


__all__ = [
    "GENERATED_MIN_WORK",
    "LANES",
    "MAX_GENERATED_TERMS",
    "adaptive_packed",
    "applies",
    "kernel",
    "pair_first",
    "run",
]

MAX_STEPS = 10_000_000
"""The full state's step budget per trajectory (status -3 beyond it): defined here, where the lane and
pair kernels run, and :data:`refimpl._full_state.MAX_STEPS` is this (that module imports this one, so
this one imports nothing of it)."""

MAX_GENERATED_TERMS = 1000
"""The most terms (numbers) of the derived and state rows for which the lane kernel is generated per
structure (:func:`refimpl.codegen.full_state_batch.batch_source`, every product written out in the
LLVM IR of :func:`refimpl.codegen._full_state_ir.lanes_order_intrinsic`): its IR, and LLVM's time on
it, grow with them. Fully cold, the kernel alone, CPU, load 1.3-2.0: free_su3 (225 terms, 140 general
products) 1.63 s, kirchhoff_se3 1.53, manakov_so4 1.49, sl(3, R) 1.57, h(3) 1.39, so(5) in its adjoint
representation (820 terms, 660 products) 2.66 s. Beyond it the one kernel compiled for every
structure, :func:`adaptive_packed` (1.8 s once, then numba's disk cache), runs: the rows from the
tables, slower per trajectory."""


GENERATED_MIN_WORK = 0.0
"""``N |T|`` (rows of one :func:`run` times the time span) from which a batch runs the lane kernel
generated for its structure (up to :data:`MAX_GENERATED_TERMS`); below it, :func:`adaptive_packed`
(compiled once for every structure). 0: every batch runs the generated one. Measured (warm, wall
best, per trajectory at 3e-14, load 2.4-2.7; /work/scratch_ir2/minwork.py, machine-local): the
generated kernel is 2.0-2.5x faster at every size, N = 4 at T = 1 to N = 64 at T = 10 (bianchi_cocycle
3.2 -> 1.6 us and 22.5 -> 10.0 us, free_su3 8.7 -> 3.5 and 40.0 -> 15.8, kirchhoff_se3 7.4 -> 3.2 and
77.8 -> 31.0); its cold compilation (0.9-1.4 s, the order body in LLVM IR) is now below
:func:`adaptive_packed`'s (1.3-1.5 s). With the former 1024, a batch of 128 over ``T = 10`` compiled
both (the control's short retry subsets took :func:`adaptive_packed`): fully cold batch first calls
(tests/benchmarks/cold_first_call.py --mode cold, load 2.2-2.8) of 128 bianchi_cocycle 2.38 -> 1.18 s,
free_su3 2.61 -> 1.35 s; of 64 1.42 -> 1.20 s, 1.37 -> 1.38 s. The cost: once numba's cache holds the
package's functions, a short batch compiles its structure's lane kernel (about 1 s, then cached),
where :func:`adaptive_packed` needed none. A function of the call's inputs, so a row's result never
depends on what ran before it."""


def applies(fs) -> bool:
    """Every structure has a lane kernel (generated up to :data:`MAX_GENERATED_TERMS`, else
    :func:`adaptive_packed`)."""
    return True


_SIG = (
    "(float64[:, ::1], float64, float64, int64, int64, float64[::1], int64[::1], int64[::1], "
    "float64[:, ::1], int64[::1])"
)
_SIG_PACKED = (
    "(float64[:, ::1], float64, float64, int64, int64, int64, int64[::1], int64[::1], int64[::1], "
    "float64[::1], int64[::1], int64[::1], int64[::1], int64[::1], int64[::1], int64[::1], "
    "float64[::1], int64[::1], int64[::1], float64[::1], bool[::1], int64[::1], int64[::1], "
    "int64[::1], int64[::1], float64[:, ::1], int64[::1])"
)


def _compile(fn, sig):
    """Compile ``fn`` for ``sig`` with LLVM's SLP vectoriser on (or load it from numba's disk cache)."""
    if fn.signatures:
        return
    from numba.core import config
    from numba.core.compiler_lock import global_compiler_lock

    with global_compiler_lock:  # no other compilation sees the flag
        old = config.SLP_VECTORIZE
        config.SLP_VECTORIZE = 1
        try:
            fn.compile(sig)
        finally:
            config.SLP_VECTORIZE = old


def kernel(fs, generated: bool = True):
    """``(fn, args)`` for the structure of ``fs`` (kept on ``fs``): ``fn(y0, T, tol, P, max_steps,
    *args, out, nsteps)``. The module generated for the structure (imported from the kernel cache,
    :func:`refimpl.codegen.import_source`), every product written out, up to
    :data:`MAX_GENERATED_TERMS`; beyond, or when not ``generated``, :func:`adaptive_packed` with the
    tables and the blocks of
    :func:`refimpl.codegen.full_state_batch.batch_groups`. Each compiled with LLVM's SLP vectoriser on
    (or loaded from numba's disk cache)."""
    key = "_batch_kernel" if generated else "_batch_kernel_tables"
    kb = fs.__dict__.get(key)
    if kb is not None:
        return kb
    tables = fs.tables()
    terms = len(tables[4]) + len(tables[11]) + len(tables[14])
    if not generated or terms > MAX_GENERATED_TERMS:
        _compile(adaptive_packed, _SIG_PACKED)
        kb = (adaptive_packed, (int(tables[0]), *tables[1:], *batch_groups(tables)))
    else:
        fn = import_source(batch_source(tables, fs.d, LANES, GROUP), "fsbatch_").adaptive_batch
        _compile(fn, _SIG)
        kb = (fn, (batch_numbers(tables), tables[8], tables[16]))
    fs.__dict__[key] = kb
    return kb


def run(fs, y0, T: float, tol: float, P: int, max_steps: int, *, generated: bool | None = None):
    """``(y(T), steps)`` for the rows of ``y0`` (N, d) at the local tolerance ``tol`` and order ``P``,
    ``W`` rows at a time (``y0`` is only read). ``generated``: the structure's own lane kernel
    (:func:`kernel`); ``None``: from ``N |T| >=`` :data:`GENERATED_MIN_WORK` on."""
    if generated is None:
        generated = y0.shape[0] * abs(T) >= GENERATED_MIN_WORK
    fn, args = kernel(fs, generated)
    y = np.ascontiguousarray(y0, dtype=float)
    out = np.empty_like(y)
    steps = np.zeros(y.shape[0], dtype=np.int64)
    fn(y, float(T), float(tol), int(P), int(max_steps), *args, out, steps)
    return out, steps


def pair_first(fs, y0, t: float, eps_a: float, eps_b: float, order_a: int, order_b: int):
    """``(A, B, steps_a, steps_b)``: the runs A (local tolerance ``eps_a``, order ``order_a``) and B
    (``eps_b``, ``order_b``) of one trajectory from its row ``y0`` (1, d) over ``t``, side by side on
    the two lanes of one vector (the generated module's ``pair``,
    :func:`refimpl.codegen.full_state.pair_lines`): each the single kernel's run
    (:meth:`refimpl._full_state.FullState.run` with ``generated=True``) at its tolerance and order,
    operation for operation, for about the cost of the longer one. ``A``, ``B``: fresh (1, d) rows
    (NaN on failure); ``steps_a``, ``steps_b``: (1,) step counts (negative: the status). ``y0`` is
    only read."""
    y = np.ascontiguousarray(y0, dtype=float)
    if y.ndim != 2 or y.shape != (1, fs.d):
        raise ValueError(f"pair_first: y0 must have shape (1, {fs.d}), got {y.shape}")
    out = np.empty((2, fs.d))
    steps = np.zeros(2, dtype=np.int64)
    fs.module().pair(
        y, float(t), float(eps_a), float(eps_b), int(order_a), int(order_b),
        MAX_STEPS, fs.coef, out, steps,
    )  # fmt: skip
    return out[:1], out[1:], steps[:1], steps[1:]


# ---------------------------------------------------------------------- the packed lane kernel
# the order body as one intrinsic, IR version 1 (rev 2) (numba's cache keys on this file: see packed_order)
_packed_order = packed_order()
# One machine-code function for every structure (short batches, and beyond MAX_GENERATED_TERMS; the field as the sparse tables of
# FullState.tables, arguments, never literals): compiled once, kept by numba's disk cache. Four lanes
# written out (LANES).


@njit(cache=True, nogil=True, fastmath={"contract"})
def adaptive_packed(y0, T, tol, P, max_steps, nv, drow, dptr, didx, dcoef, pu, pw, pcls, vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon, srow, gp, gu, gw, out, nsteps):  # fmt: skip
    """The packed lane kernel: :func:`refimpl._full_state_kernel.adaptive` (the same tables, the same
    results per row) with the rows of ``y0`` four at a time in lanes, each lane its own trajectory,
    step, step count and status (a finished lane takes the next row of the queue, an idle one holds
    the zero state and steps by 0); the general products in the 2 x 4 blocks ``gp, gu, gw`` of
    :func:`refimpl.codegen.full_state_batch.batch_groups` (``V`` rows: the tables' ``nv`` named rows,
    the products, the zero row, the sink row).

    The order body is the intrinsic :func:`refimpl.codegen._full_state_ir.packed_order` (LLVM IR on
    vectors of the four lanes, each lane's operations those of the numba Python loops it replaced):
    compiled from empty caches, alone, CPU, load 2.6: 3.11 -> 1.79 s; end states bitwise equal and
    per trajectory faster (128 trajectories, interleaved, best of 10, CPU, load 2.6-2.7, at 3e-14:
    kirchhoff_se3 92.5 -> 74.7 us, free_su3 48.6 -> 39.8, manakov_so4 35.3 -> 31.0, bianchi_cocycle
    28.8 -> 22.6)."""
    N, d = y0.shape
    npr = pu.shape[0]
    V = np.zeros((P + 1, nv + npr + 2, 4))
    ngrp = gu.shape[0] // 2
    UB = np.zeros((max(ngrp, 1), P + 1, 2, 4))
    WB = np.zeros((max(ngrp, 1), P + 1, 4, 4))
    nvar = vrow.shape[0]
    comp = np.zeros((max(nvar, 1), 4))
    tl = np.zeros(4)
    hv = np.zeros(4)
    who = np.full(4, -1, dtype=np.int64)
    nst = np.zeros(4, dtype=np.int64)
    stat = np.zeros(4, dtype=np.int64)
    sgn = 1.0 if T >= 0 else -1.0
    Tabs = abs(T)
    damp = math.exp(-0.7 / (P - 1))
    e1 = 1.0 / (P - 1)
    e2 = 1.0 / P
    nxt = 0
    live = 0
    for ln in range(4):
        if nxt < N:
            for q in range(d):
                V[0, q, ln] = y0[nxt, q]
            who[ln] = nxt
            nxt += 1
            live += 1
    while live > 0:
        # the Taylor coefficients V[1..P] (the recurrence of _full_state_kernel.coefficients, four
        # lanes): LLVM IR on vectors of the four lanes (codegen._full_state_ir.packed_order)
        for k in range(P):
            _packed_order(V, UB, WB, k, nv, drow, dptr, didx, dcoef, gp, gu, gw, pu, pw, pcls, vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon)  # fmt: skip
        for ln in range(4):
            hv[ln] = 0.0
            if who[ln] < 0:
                continue
            xn = 0.0
            m1 = 0.0
            m2 = 0.0
            for q in range(srow.shape[0]):
                o = srow[q]
                xn = max(xn, abs(V[0, o, ln]))
                m1 = max(m1, abs(V[P - 1, o, ln]))
                m2 = max(m2, abs(V[P, o, ln]))
            s = tol * max(1.0, xn)
            h = np.inf
            if m1 > 0.0:
                h = (s / m1) ** e1
            if m2 > 0.0:
                h = min(h, (s / m2) ** e2)
            h *= damp
            if not (h > 0.0):
                stat[ln] = -4
                continue
            if tl[ln] + h >= Tabs:
                h = Tabs - tl[ln]
                tl[ln] = Tabs
            else:
                tl[ln] += h
            hv[ln] = sgn * h
        h0, h1, h2, h3 = hv[0], hv[1], hv[2], hv[3]
        for c in range(nvar):
            o = vrow[c]
            z0 = V[P, o, 0]
            z1 = V[P, o, 1]
            z2 = V[P, o, 2]
            z3 = V[P, o, 3]
            for kk in range(P - 1, 0, -1):
                z0 = z0 * h0 + V[kk, o, 0]
                z1 = z1 * h1 + V[kk, o, 1]
                z2 = z2 * h2 + V[kk, o, 2]
                z3 = z3 * h3 + V[kk, o, 3]
            z0 = z0 * h0 - comp[c, 0]
            z1 = z1 * h1 - comp[c, 1]
            z2 = z2 * h2 - comp[c, 2]
            z3 = z3 * h3 - comp[c, 3]
            v0 = V[0, o, 0]
            v1 = V[0, o, 1]
            v2 = V[0, o, 2]
            v3 = V[0, o, 3]
            w0 = v0 + z0
            w1 = v1 + z1
            w2 = v2 + z2
            w3 = v3 + z3
            comp[c, 0] = (w0 - v0) - z0
            comp[c, 1] = (w1 - v1) - z1
            comp[c, 2] = (w2 - v2) - z2
            comp[c, 3] = (w3 - v3) - z3
            V[0, o, 0] = w0
            V[0, o, 1] = w1
            V[0, o, 2] = w2
            V[0, o, 3] = w3
        for ln in range(4):
            if who[ln] < 0:
                continue
            if stat[ln] == 0:
                nst[ln] += 1
                for c in range(nvar):
                    if not math.isfinite(V[0, vrow[c], ln]):
                        stat[ln] = -1
                if nst[ln] > max_steps:
                    stat[ln] = -3
            if stat[ln] == 0 and tl[ln] < Tabs:
                continue
            it = who[ln]
            for q in range(d):
                out[it, q] = V[0, q, ln] if stat[ln] == 0 else np.nan
            nsteps[it] = nst[ln] if stat[ln] == 0 else stat[ln]
            for c in range(nvar):
                comp[c, ln] = 0.0
            tl[ln] = 0.0
            nst[ln] = 0
            stat[ln] = 0
            if nxt < N:
                for q in range(d):
                    V[0, q, ln] = y0[nxt, q]
                who[ln] = nxt
                nxt += 1
            else:
                for q in range(d):
                    V[0, q, ln] = 0.0
                who[ln] = -1
                live -= 1
