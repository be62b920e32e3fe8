"""The lane-batched kernel of the compiled full state (:mod:`refimpl._full_state`), one per structure.

``W`` trajectories run side by side in lanes (template ``full_state_batch``): the Taylor coefficients
are laid out ``V[k, row, lane]`` (C order), so the ``W`` lanes of one coefficient are contiguous, and
every statement of the recurrence is written out once per lane. The Cauchy products -- ``(#products)
P^2 / 2`` multiply-adds per step, the bulk of the work -- are summed ``GROUP`` products at a time into
rows of ``V`` of their own (``V[k, nv + p, lane]``): the lanes' adjacent stores are the seeds from
which LLVM's SLP vectoriser packs loads, multiply-adds and stores into SIMD instructions across the
lanes (measured on se(3) at order 20, one run: 2.6x fewer CPU seconds per trajectory than the
single-trajectory generated kernel; accumulators held in scalars instead were packed across
*products*, with shuffles, and gained nothing). No reassociation flag is needed (``fastmath`` is
``contract`` only, as in the single-trajectory kernels), so every lane sums its products in the order
``a = 0..k`` of :mod:`refimpl._full_state_kernel`; only the choice of fused multiply-adds may differ.

The source is generated from the sparse tables of :meth:`refimpl._full_state.FullState.tables` (the
one description of the field, shared with the kernel compiled for every structure): their index
arrays are the structure and are written into the source; their numbers (``dcoef``, ``qcoef``,
``lcoef``) are one argument array ``c``, read into locals once per call. So the source, and the cache
key of its machine code, depends on the nonzero patterns only, never on the values.

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

GROUP = 8
"""General Cauchy products summed in one loop over ``a`` (se(3), order 20, one run: 8 products 59 us
per trajectory, 4 products 63 us, 2 products 71 us)."""


def _sum(terms: list[str]) -> str:
    return tree_sum(terms) if terms else "0.0"


def batch_numbers(tables) -> np.ndarray:
    """The argument ``c`` of :func:`batch_source`'s kernel: ``dcoef``, ``qcoef``, ``lcoef`` of the tables."""
    return np.ascontiguousarray(np.concatenate([tables[4], tables[11], tables[14]]), dtype=float)


def batch_source(tables, d: int, W: int = LANES, group: int = GROUP) -> str:
    """The kernel module ``adaptive_batch(y0, T, tol, P, max_steps, c, vrow, srow, out, nsteps)`` for the
    field given by the sparse ``tables`` of :meth:`refimpl._full_state.FullState.tables` (``d`` state
    variables, ``W`` lanes, the general Cauchy products summed ``group`` at a time); ``c`` is
    :func:`batch_numbers` of the same tables, ``vrow``/``srow`` the tables' rows of the same name."""
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

    kb: list[str] = []
    for r in range(len(drow)):  # derived rows: Omega_k = I^-1 pi_k, then M_k = rho(Omega_k)
        ts = range(dptr[r], dptr[r + 1])
        for ln in lanes:
            kb.append(
                f"{at('k', drow[r], ln)} = " + _sum([f"c{t} * {at('k', didx[t], ln)}" for t in ts])
            )
    general = [p for p in range(len(pu)) if pcls[p] == 0]
    for g0 in range(0, len(general), group):
        grp = general[g0 : g0 + group]
        kb += [f"{at('k', nv + p, ln)} = 0.0" for p in grp for ln in lanes]
        kb += ["for a in range(k + 1):", I1 + "b = k - a"]
        kb += [
            I1 + f"{at('k', nv + p, ln)} += {at('a', pu[p], ln)} * {at('b', pw[p], ln)}"
            for p in grp
            for ln in lanes
        ]
    for p in range(len(pu)):
        u, w, cl = pu[p], pw[p], pcls[p]
        for ln in lanes:
            if cl == 1:
                kb.append(f"p{p}_{ln} = {at(0, u, ln)} * {at('k', w, ln)}")
            elif cl == 2:
                kb.append(f"p{p}_{ln} = {at('k', u, ln)} * {at(0, w, ln)}")
            elif cl == 3:
                kb.append(f"p{p}_{ln} = {at(0, u, ln)} * {at(0, w, ln)} if k == 0 else 0.0")
            # class 5: the padding of the compiled-for-every-structure kernel, never read
    kb.append("ik = 1.0 / (k + 1)")
    for cv in range(len(vrow)):
        for ln in lanes:
            terms = [
                f"c{off_q + t} * "
                + (at("k", nv + qprod[t], ln) if pcls[qprod[t]] == 0 else f"p{qprod[t]}_{ln}")
                for t in range(qptr[cv], qptr[cv + 1])
            ]
            for t in range(lptr[cv], lptr[cv + 1]):
                if lcon[t]:
                    terms.append(f"(c{off_l + t} * {at(0, lvar[t], ln)} if k == 0 else 0.0)")
                else:
                    terms.append(f"c{off_l + t} * {at('k', lvar[t], ln)}")
            kb.append(f"{at('k + 1', vrow[cv], ln)} = ({_sum(terms)}) * ik")
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
        NV=str(int(nv) + len(pu)),
        D=str(int(d)),
        W=str(W),
    )
