"""The lane-batched kernel of the compiled full state (:mod:`refimpl._full_state`), one per structure.

``W`` trajectories run side by side in lanes (template ``full_state_batch``): the Taylor coefficients
are laid out ``V[k, row, lane]`` (C order), so the ``W`` lanes of one coefficient are contiguous. The
order body of the recurrence is the intrinsic ``_order(V, k, C)``
(:func:`refimpl.codegen._full_state_ir.lanes_order_intrinsic`, LLVM IR built from the literal
:func:`batch_spec` in the source) on vectors of ``W`` float64: the derived rows, then the Cauchy
products -- ``(#products) P^2 / 2`` multiply-adds per step, the bulk of the work -- summed ``GROUP``
products at a time in one loop over ``a``, one vector accumulator per product (the loop stores nothing,
so its sums stay in registers), products grouped by shared factors (:func:`share_groups`: a group's
factor rows are loaded once per ``a``), then the state rows. No reassociation flag is needed
(``fastmath`` is ``contract`` only, as in the single-trajectory kernels): every lane sums its
products in the order ``a = 0..k``. Measured before the IR (1000 trajectories, CPU per trajectory,
see :data:`GROUP`): kirchhoff_se3 at 3e-14 35.6 us against 50.3 us with the sums kept in rows of
``V``; loads per ``a`` for all groups, kirchhoff_se3 40 against 50 sorted by factor (45 products),
manakov_so4 48 against 82 (72 products).

Compile time (issue 25): as numba Python (every statement in a loop over the lanes) the per-order
body cost numba's front end 5-9 s per structure, so structures beyond a size had a packed form
(products in blocks through index tables: slower per trajectory). As IR every structure up to
:data:`refimpl._full_state_batch.MAX_GENERATED_TERMS` has every product written out: fully cold, the
kernel alone, CPU, load 1.3-2.0 (``/work/scratch_ir/cold_all.sh batch``, a machine-local script),
manakov_so4 8.4 -> 1.49 s, sl(3) 8.8 -> 1.57, free_su3 5.3 -> 1.63 (was packed), kirchhoff_se3 1.53,
Bianchi VI0 with a cocycle 2.2 -> 1.39. Per trajectory (kernel alone, 256 trajectories, interleaved in
one process, best of 10, CPU, load 1.4-1.8, at 3e-14): kirchhoff_se3 34.6 -> 30.5 us, manakov_so4
14.3 -> 12.9, bianchi_cocycle 10.7 -> 10.0, sl(3) 3.1 -> 2.6 (these four bitwise equal to the numba
Python kernel), free_su3 34.4 -> 13.9 (the packed form before; within 2.5e-15 relative).

The source is generated from the sparse tables of :meth:`refimpl._full_state.FullState.tables` (the
one description of the field, shared with the kernel compiled for every structure): their index
arrays are the structure and are written into the source; their numbers (``dcoef``, ``qcoef``,
``lcoef``) are one argument array ``c``, read into a tuple once per call. So the source, and the cache
key of its machine code, depends on the nonzero patterns only, never on the values.

Each lane keeps its own time, step and step count: a trajectory takes the steps it takes in the
single-trajectory kernel (Jorba-Zou's step from its own coefficients, per lane), and keeps its own
error estimate and its own failure status.

:func:`batch_groups` gives the 2 x 4 blocks of products of the kernel compiled for every structure,
:func:`refimpl._full_state_batch.adaptive_packed` (six loads for eight multiply-adds per ``a``).
"""

from __future__ import annotations

import numpy as np

from . import _full_state_ir as ir
from ._loader import fill, template

__all__ = ["GROUP", "LANES", "batch_numbers", "batch_source", "batch_spec"]

LANES = 4
"""Trajectories per lane block (``W``): four float64 lanes fill one 256-bit SIMD register."""

GROUP = 12
"""General Cauchy products summed in one loop over ``a``, one accumulator per product (its ``W`` lanes:
one vector register; measured when the kernel was numba Python with an accumulator per product and
lane, kirchhoff_se3 at 3e-14, order 21, 1000 trajectories, one run each at load ~4.5, kernel CPU
per trajectory): 6 products 40.7 us, 9 36.7, 12 35.6, 15 34.1, 23 33.9, all 45 at once 46.1 (spills);
the earlier accumulation into rows of ``V`` (stored on every ``a``: LLVM cannot prove the row apart
from the loads) 50.3 us at 6. Twelve keeps ``12 W`` accumulators within the sixteen 256-bit registers
plus spare (AVX2; AVX-512 has 32), a margin for machines without AVX-512."""


BLOCK = (2, 4)
"""``(BU, BW)``: :func:`batch_groups`' blocks of products ``u_i w_j`` (two rows ``u``, four rows ``w``):
per ``a``, six loads for eight multiply-adds."""


def share_groups(prods, pu, pw, size: int) -> list[list[int]]:
    """``prods`` in groups of at most ``size`` whose factors overlap (greedy): a group's factor rows are
    loaded once per ``a`` (LLVM merges the equal loads of the store-free loop), so a group of ``u_i
    w_j`` products over a few ``u`` and a few ``w`` costs fewer loads than multiply-adds. Each group
    starts at the first product left and takes, while it has room, the product adding the fewest new
    factor rows (ties: the earliest); deterministic, from the structure only."""
    left = list(prods)
    out: list[list[int]] = []
    while left:
        grp = [left.pop(0)]
        have = {("u", pu[grp[0]]), ("w", pw[grp[0]])}
        while left and len(grp) < size:
            best, cost = 0, 3
            for i, p in enumerate(left):
                c = (("u", pu[p]) not in have) + (("w", pw[p]) not in have)
                if c < cost:
                    best, cost = i, c
                    if c == 0:
                        break
            p = left.pop(best)
            grp.append(p)
            have |= {("u", pu[p]), ("w", pw[p])}
        out.append(grp)
    return out


def batch_numbers(tables) -> np.ndarray:
    """The argument ``c`` of :func:`batch_source`'s kernel: ``dcoef``, ``qcoef``, ``lcoef`` of the tables."""
    return np.ascontiguousarray(np.concatenate([tables[4], tables[11], tables[14]]), dtype=float)


def batch_spec(tables, group: int = GROUP) -> tuple:
    """The structure of the sparse ``tables`` as the literal spec of
    :func:`refimpl.codegen._full_state_ir.lanes_order_intrinsic`: ``(ncoef, derived, groups, consts,
    state)``, the coefficient indices into :func:`batch_numbers`, the general products in the
    :func:`share_groups` of ``group``."""
    (nv, drow, dptr, didx, dcoef, pu, pw, pcls, vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon,
     srow) = tables  # fmt: skip
    off_q = len(dcoef)
    off_l = off_q + len(qcoef)
    ncoef = off_l + len(lcoef)
    derived = tuple(
        (int(drow[r]), tuple((t, int(didx[t])) for t in range(dptr[r], dptr[r + 1])))
        for r in range(len(drow))
    )
    general = [p for p in range(len(pu)) if pcls[p] == 0]
    groups = tuple(
        tuple((p, int(pu[p]), int(pw[p])) for p in grp)
        for grp in share_groups(general, pu, pw, group)
    )
    consts = tuple(
        (p, int(pu[p]), int(pw[p]), int(pcls[p])) for p in range(len(pu)) if pcls[p] in (1, 2, 3)
    )  # class 5: the padding of the compiled-for-every-structure kernel, never read
    state = []
    for cv in range(len(vrow)):
        terms = [(ir.SCALED, off_q + t, int(qprod[t])) for t in range(qptr[cv], qptr[cv + 1])]
        terms += [
            (ir.LIN_CONST if lcon[t] else ir.LIN, off_l + t, int(lvar[t]))
            for t in range(lptr[cv], lptr[cv + 1])
        ]
        state.append((int(vrow[cv]), tuple(terms)))
    return (ncoef, derived, groups, consts, tuple(state))


def batch_source(tables, d: int, W: int = LANES, group: int = GROUP) -> str:
    """The kernel module ``adaptive_batch(y0, T, tol, P, max_steps, c, vrow, srow, out, nsteps)`` for
    the field given by the sparse ``tables`` of :meth:`refimpl._full_state.FullState.tables` (``d``
    state variables, ``W`` lanes, the general Cauchy products summed ``group`` at a time); ``c`` is
    :func:`batch_numbers` of the same tables, ``vrow``/``srow`` the tables' rows of the same name."""
    if not (isinstance(W, int) and 1 <= W <= 16):
        raise ValueError(f"lanes W must be an int in 1..16, got {W!r}")
    if not (isinstance(group, int) and group >= 1):
        raise ValueError(f"group must be a positive int, got {group!r}")
    sp = batch_spec(tables, group)
    lanes = range(W)
    I1 = "    "
    head = [
        "from tstarg.refimpl.codegen import _full_state_ir",
        "",
        f"# the structure (refimpl.codegen.full_state_batch.batch_spec, IR version {ir.IR_VERSION}):",
        "# ncoef, derived rows, product groups, products with a constant factor, state rows",
        f"SPEC = {sp!r}",
        f"_order = _full_state_ir.lanes_order_intrinsic(SPEC, {W})",
        f"_load = _full_state_ir.load_intrinsic({sp[0]})",
    ]
    return fill(
        template("full_state_batch"),
        HEAD="\n".join(head),
        NCOEF=str(sp[0]),
        HLOAD="\n".join(2 * I1 + f"h_{ln} = hv[{ln}]" for ln in lanes),
        ZLOAD="\n".join(3 * I1 + f"z_{ln} = V[P, o, {ln}]" for ln in lanes),
        ZSTEP="\n".join(4 * I1 + f"z_{ln} = z_{ln} * h_{ln} + V[kk, o, {ln}]" for ln in lanes),
        ZADD="\n".join(
            3 * I1 + x
            for ln in lanes
            for x in (
                f"z_{ln} = z_{ln} * h_{ln} - comp[cv, {ln}]",
                f"v_{ln} = V[0, o, {ln}]",
                f"w_{ln} = v_{ln} + z_{ln}",
                f"comp[cv, {ln}] = (w_{ln} - v_{ln}) - z_{ln}",
                f"V[0, o, {ln}] = w_{ln}",
            )
        ),
        NV=str(int(tables[0])),
        D=str(int(d)),
        W=str(W),
    )


def batch_groups(tables) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(gp, gu, gw)`` of :func:`refimpl._full_state_batch.adaptive_packed`: the general products covered by blocks of ``BU x BW`` =
    :data:`BLOCK` (``gu``: a block's ``BU`` factor rows ``u``, ``gw``: its ``BW`` rows ``w``, ``gp``: the
    ``V`` row of the product of each pair ``(u_i, w_j)``, row-major), every product in exactly one block;
    a pair that is no product multiplies or is written to rows nobody reads (the zero row ``nv +
    len(pu)`` as a missing factor, the sink row ``nv + len(pu) + 1`` as its output).

    Greedy, from the structure only: the ``u`` with the most products left opens a block, the ``u``
    sharing most of its ``w`` joins it (up to ``BU``), and the block takes up to ``BW`` of the ``w``
    they share most (ties: the smallest row)."""
    nv, pu, pw, pcls = int(tables[0]), np.asarray(tables[5]), np.asarray(tables[6]), tables[7]
    BU, BW = BLOCK
    zero, sink = nv + len(pu), nv + len(pu) + 1
    left: dict[int, dict[int, int]] = {}  # u -> {w: product}
    for q in np.flatnonzero(np.asarray(pcls) == 0):
        left.setdefault(int(pu[q]), {})[int(pw[q])] = int(q)
    gp: list[int] = []
    gu: list[int] = []
    gw: list[int] = []
    while left:
        u0 = min(left, key=lambda u: (-len(left[u]), u))
        us = [u0]
        while len(us) < BU:
            cands = [u for u in left if u not in us]
            if not cands:
                break
            best = min(cands, key=lambda u: (-len(left[u].keys() & left[u0].keys()), u))
            if not left[best].keys() & left[u0].keys():
                break
            us.append(best)
        ws = sorted(
            {w for u in us for w in left[u]},
            key=lambda w: (-sum(w in left[u] for u in us), w),
        )[:BW]
        for u in us:
            gu.append(u)
        gu += [zero] * (BU - len(us))
        gw += ws + [zero] * (BW - len(ws))
        for i in range(BU):
            for j in range(BW):
                u = us[i] if i < len(us) else None
                w = ws[j] if j < len(ws) else None
                q = left.get(u, {}).pop(w, None) if u is not None and w is not None else None
                gp.append(sink if q is None else nv + q)
        for u in us:
            if not left[u]:
                del left[u]
    i64 = lambda a: np.array(a, dtype=np.int64)  # noqa: E731
    return i64(gp), i64(gu), i64(gw)
