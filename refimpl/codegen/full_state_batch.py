"""The lane-batched kernel of the compiled full state (:mod:`refimpl._full_state`), one per structure.

``W`` trajectories run side by side in lanes (template ``full_state_batch``): the Taylor coefficients
are laid out ``V[k, row, lane]`` (C order), so the ``W`` lanes of one coefficient are contiguous, and
every statement of the recurrence sits in a loop ``for l in range(W)`` over the lanes, except the
Cauchy products -- ``(#products) P^2 / 2`` multiply-adds per step, the bulk of the work -- which are
summed ``GROUP`` products at a time in one loop over ``a``, with one scalar accumulator per product and
lane written out (``s{j}_{l}``): the loop body stores nothing, so its sums stay in registers, and LLVM's
SLP vectoriser packs the ``W`` lanes' adjacent loads and multiply-adds into SIMD instructions; products
are grouped by shared factors, so a group's shared factor is loaded once. No reassociation flag is needed
(``fastmath`` is ``contract`` only, as in the single-trajectory kernels): every lane sums its products
in the order ``a = 0..k``. Measured (1000 trajectories, CPU per trajectory, see :data:`GROUP`):
kirchhoff_se3 at 3e-14 35.6 us against 50.3 us with the sums kept in rows of ``V``. The groups are
chosen to share factor rows (:func:`share_groups`): loads per ``a`` for all groups, kirchhoff_se3 40
against 50 sorted by factor (45 products), manakov_so4 48 against 82 (72 products); one run each, load
~7.5: kirchhoff_se3 35.4 against 37.6 us, manakov_so4 15.0 against 17.0 us per trajectory.

The packed form (``packed=True``, for structures too large to write every product out: see
:data:`refimpl._full_state_batch.MAX_SIZE`) sums the general products :data:`PACK` at a time through
index tables (:func:`batch_groups`): at each order the ``k``-th coefficients of a group's factors are
copied into blocks ``UB[g, k, j, lane]``, ``WB[g, k, j, lane]`` and one fixed loop over ``a`` sums them
with scalar accumulators; the source is then short whatever the number of products (numba's typing and
lowering, most of a cold compilation, grow with the statements), the sums the same in the same order.

The source is generated from the sparse tables of :meth:`refimpl._full_state.FullState.tables` (the
one description of the field, shared with the kernel compiled for every structure): their index
arrays are the structure and are written into the source; their numbers (``dcoef``, ``qcoef``,
``lcoef``) are one argument array ``c``, read into locals once per call. So the source, and the cache
key of its machine code, depends on the nonzero patterns only, never on the values. Written with the
lane loops (not one statement per lane) the source stays short: a cold compilation of so(4) takes
about 7 s (22 s with the lanes written out).

Each lane keeps its own time, step and step count: a trajectory takes the steps it takes in the
single-trajectory kernel (Jorba-Zou's step from its own coefficients, per lane), and keeps its own
error estimate and its own failure status.
"""

from __future__ import annotations

import numpy as np

from ._loader import fill, template
from .taylor import tree_sum

__all__ = ["GROUP", "LANES", "batch_numbers", "batch_source"]

LANES = 4
"""Trajectories per lane block (``W``): four float64 lanes fill one 256-bit SIMD register."""

GROUP = 12
"""General Cauchy products summed in one loop over ``a``, each lane of each product in a scalar
accumulator (kirchhoff_se3 at 3e-14, order 21, 1000 trajectories, one run each at load ~4.5, kernel CPU
per trajectory): 6 products 40.7 us, 9 36.7, 12 35.6, 15 34.1, 23 33.9, all 45 at once 46.1 (spills);
the earlier accumulation into rows of ``V`` (stored on every ``a``: LLVM cannot prove the row apart
from the loads) 50.3 us at 6. Twelve keeps ``12 W`` accumulators within the sixteen 256-bit registers
plus spare (AVX2; AVX-512 has 32), a margin for machines without AVX-512."""


PACK = 8
"""General products per group in the packed form of :func:`batch_source` (``packed=True``)."""


def _sum(terms: list[str]) -> str:
    return tree_sum(terms) if terms else "0.0"


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


def batch_source(tables, d: int, W: int = LANES, group: int = GROUP, packed: bool = False) -> str:
    """The kernel module ``adaptive_batch(y0, T, tol, P, max_steps, c, vrow, srow, gp, gu, gw, out,
    nsteps)`` for the field given by the sparse ``tables`` of :meth:`refimpl._full_state.FullState.tables`
    (``d`` state variables, ``W`` lanes, the general Cauchy products written out and summed ``group``
    at a time, or ``packed`` :data:`PACK` at a time through index tables); ``c`` is
    :func:`batch_numbers` of the same tables, ``vrow``/``srow`` the tables' rows of the same name,
    ``gp``/``gu``/``gw`` :func:`batch_groups` (read by the packed form only)."""
    if not (isinstance(W, int) and 1 <= W <= 16):
        raise ValueError(f"lanes W must be an int in 1..16, got {W!r}")
    if not (isinstance(group, int) and group >= 1):
        raise ValueError(f"group must be a positive int, got {group!r}")
    (nv, drow, dptr, didx, dcoef, pu, pw, pcls, vrow, qptr, qprod, qcoef, lptr, lvar, lcoef, lcon,
     srow) = tables  # fmt: skip
    off_q = len(dcoef)
    off_l = off_q + len(qcoef)
    ncoef = off_l + len(lcoef)
    lanes = range(W)
    I1 = "    "

    def at(k, row, lane):  # V[k, row, lane]: the W lanes of one coefficient are contiguous
        return f"V[{k}, {int(row)}, {lane}]"

    kb: list[str] = [f"for l in range({W}):"]
    for r in range(len(drow)):  # derived rows: Omega_k = I^-1 pi_k, then M_k = rho(Omega_k)
        ts = range(dptr[r], dptr[r + 1])
        kb.append(
            I1
            + f"{at('k', drow[r], 'l')} = "
            + _sum([f"c{t} * {at('k', didx[t], 'l')}" for t in ts])
        )
    if packed:
        G = PACK
        kb += [
            "for g in range(ngrp):",
            I1 + f"for j in range({G}):",
            2 * I1 + f"u = gu[g * {G} + j]",
            2 * I1 + f"w = gw[g * {G} + j]",
        ]
        # all loads before the stores: the W lanes then move as one SIMD load and store each (the
        # blocks are not known apart from V, so a store between two loads would keep them scalar)
        kb += [2 * I1 + f"t{ln} = V[k, u, {ln}]" for ln in lanes]
        kb += [2 * I1 + f"r{ln} = V[k, w, {ln}]" for ln in lanes]
        kb += [2 * I1 + f"UB[g, k, j, {ln}] = t{ln}" for ln in lanes]
        kb += [2 * I1 + f"WB[g, k, j, {ln}] = r{ln}" for ln in lanes]
        kb += [I1 + f"s{j}_{ln} = 0.0" for j in range(G) for ln in lanes]
        kb += [I1 + "for a in range(k + 1):", 2 * I1 + "b = k - a"]
        kb += [
            2 * I1 + f"s{j}_{ln} += UB[g, a, {j}, {ln}] * WB[g, b, {j}, {ln}]"
            for j in range(G)
            for ln in lanes
        ]
        for j in range(G):
            kb.append(I1 + f"q = gp[g * {G} + {j}]")
            kb += [I1 + f"V[k, q, {ln}] = s{j}_{ln}" for ln in lanes]
    else:
        general = [p for p in range(len(pu)) if pcls[p] == 0]
        for grp in share_groups(general, pu, pw, group):
            # one scalar accumulator per (product, lane): the loop stores nothing, so nothing it loads
            # can alias a store and the sums stay in registers; SLP packs each product's W lanes
            kb += [f"s{j}_{ln} = 0.0" for j in range(len(grp)) for ln in lanes]
            kb += ["for a in range(k + 1):", I1 + "b = k - a"]
            kb += [
                I1 + f"s{j}_{ln} += {at('a', pu[p], ln)} * {at('b', pw[p], ln)}"
                for j, p in enumerate(grp)
                for ln in lanes
            ]
            kb += [f"{at('k', nv + p, ln)} = s{j}_{ln}" for j, p in enumerate(grp) for ln in lanes]
    kb += ["ik = 1.0 / (k + 1)", f"for l in range({W}):"]
    for p in range(len(pu)):
        u, w, cl = pu[p], pw[p], pcls[p]
        if cl == 1:
            kb.append(I1 + f"{at('k', nv + p, 'l')} = {at(0, u, 'l')} * {at('k', w, 'l')}")
        elif cl == 2:
            kb.append(I1 + f"{at('k', nv + p, 'l')} = {at('k', u, 'l')} * {at(0, w, 'l')}")
        elif cl == 3:
            kb.append(
                I1
                + f"{at('k', nv + p, 'l')} = {at(0, u, 'l')} * {at(0, w, 'l')} if k == 0 else 0.0"
            )
        # class 5: the padding of the compiled-for-every-structure kernel, never read
    for cv in range(len(vrow)):
        terms = [
            f"c{off_q + t} * {at('k', nv + qprod[t], 'l')}" for t in range(qptr[cv], qptr[cv + 1])
        ]
        for t in range(lptr[cv], lptr[cv + 1]):
            if lcon[t]:
                terms.append(f"(c{off_l + t} * {at(0, lvar[t], 'l')} if k == 0 else 0.0)")
            else:
                terms.append(f"c{off_l + t} * {at('k', lvar[t], 'l')}")
        kb.append(I1 + f"{at('k + 1', vrow[cv], 'l')} = ({_sum(terms)}) * ik")
    return fill(
        template("full_state_batch"),
        LOADS="\n".join(I1 + f"c{i} = c[{i}]" for i in range(ncoef)) or I1 + "pass",
        COEFF="\n".join(3 * I1 + x for x in kb),
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
        NV=str(int(nv) + len(pu) + 2),
        NGRP=str(-(-int((np.asarray(pcls) == 0).sum()) // PACK) if packed else 0),
        PACK=str(PACK),
        D=str(int(d)),
        W=str(W),
    )


def batch_groups(tables) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(gp, gu, gw)``: the general products in groups of :data:`PACK` -- each entry the ``V`` row of
    the product and of its two factors; the last group padded with products of the zero row
    (``nv + len(pu)``) written to the sink row (``nv + len(pu) + 1``)."""
    nv, pu, pw, pcls = int(tables[0]), tables[5], tables[6], tables[7]
    gen = np.flatnonzero(np.asarray(pcls) == 0)
    pad = (-len(gen)) % PACK
    zero, sink = nv + len(pu), nv + len(pu) + 1
    gp = np.concatenate([nv + gen, np.full(pad, sink)]).astype(np.int64)
    gu = np.concatenate([np.asarray(pu)[gen], np.full(pad, zero)]).astype(np.int64)
    gw = np.concatenate([np.asarray(pw)[gen], np.full(pad, zero)]).astype(np.int64)
    return gp, gu, gw
