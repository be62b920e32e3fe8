"""The generated kernel of the compiled full state (:mod:`refimpl._full_state`), one per structure.

The source depends only on the structure of the field -- which variables exist, which are constant,
the nonzero patterns of ``I^-1``, ``f``, ``Theta``, ``G_L`` and of the representation's ``E_b`` --
and reads every number from one array ``c`` (a tuple ``C`` loaded once per call). Per order ``k``
the intrinsic ``_order(V, k, C)`` (:mod:`refimpl.codegen._full_state_ir`, LLVM IR built from the
literal :func:`spec` in the source): the derived rows (``Omega_k``, then ``M_k = rho(Omega_k)``), the
Cauchy products (independent sums side by side in loops over ``a``), the state rows from their
terms. Per step the compensated Horner update of the non-constant rows is the intrinsic
``_update`` (the rows' chains side by side in one loop; each row's operations in the order of the
Python loop it replaced: bitwise equal on the four bench structures), the step control numba
Python around it (with both intrinsics, against the numba Python kernel of 58f381e in one run, at
2e-15, interleaved, best of 300, load 1.9-2.3: kirchhoff_se3 111.3 -> 99.5 us, manakov_so4 49.3 ->
43.2, free_su3 72.1 -> 65.9, bianchi_cocycle 32.2 -> 31.6); the recurrence and control as :mod:`refimpl._full_state_kernel` (the kernel compiled for every structure, same recurrence; this one
unrolls the products: about 2.2x faster per step).

Compile time (issue 25): the order body as IR instead of Python statements, fully cold (empty numba
and kernel caches, the kernel alone, CPU, load 0.9-1.3; ``/work/scratch_ir/cold_all.sh``, a
machine-local script): free su(3) 3.59 -> 1.22 s, kirchhoff se(3) 1.81 -> 0.94, manakov so(4) 2.15 ->
0.99, sl(3) 2.67 -> 1.03, Bianchi VI0 with a cocycle 1.30 -> 0.94, the free so(5) top (adjoint
representation, 660 products) 10.0 -> 2.15. The same operations in the same order as the Python
source it replaces (end states bitwise equal on kirchhoff_se3, free_su3, manakov_so4 and
bianchi_cocycle at 1e-6 and 2e-15), and per call equal or faster (no index wraparound checks; kernel
alone, interleaved in one process, best of 300, CPU, load 0.9-1.1, at 2e-15: kirchhoff_se3 111.7 ->
102.0 us, free_su3 71.7 -> 66.5, manakov_so4 50.0 -> 44.2, bianchi_cocycle 32.4 -> 32.9).
"""

from __future__ import annotations

from . import _full_state_ir as ir
from .rational import adaptive_step_lines
from .taylor import _JIT

__all__ = ["full_state_source", "spec"]


PRODUCT_CHUNK = 16
"""Cauchy products summed side by side in one loop over ``a`` (each sum in the order ``a = 0..k``);
more products than this take several loops (compile time grows faster than linearly with a loop's
body). The general products are ordered by their second factor, then their first, before they are
cut into loops: products sharing ``V[w, k - a]`` sit in one loop, which loads it once per ``a``
(the order of the sums' names only: every product is the same sum in the same order, the state rows
read the same names; the compiler may contract a different subset of the multiply-adds into FMAs, one
rounding each way: kirchhoff_se3 bitwise equal, free_su3 within 1.7e-15 of the old order, same step
counts). Measured against the order of first appearance, interleaved in one process,
best of 100, CPU, load 2.2-2.6, kernel at ``eps = 2e-15`` (order 22) and the protocol flow:
kirchhoff_se3 163 -> 112 us, flow 262 -> 199 us; free_su3 117 -> 70 us, flow 219 -> 156 us;
manakov_so4 86 -> 48 us, flow 165 -> 115 us; bianchi_cocycle 34.1 -> 31.9 us, flow 93 -> 90 us;
compile time unchanged (su(3) 3.9-4.0 s). So ordered, 8, 16 or 32 per loop are alike (su(3): 71, 70,
69 us). In each loop every distinct factor is read once per ``a`` (free_su3 70.9 -> 63.5 us at
``2e-15``, kirchhoff_se3 114.9 -> 113.1, manakov_so4 48.5 -> 48.2, when this was numba Python; the
same multiply-adds in the same order)."""


PACK_LANES = 4
"""General products per vector in the single kernel's order body (:func:`refimpl.codegen.
_full_state_ir.order_intrinsic`, :func:`refimpl.codegen._full_state_ir.pack_plan`); the pair
kernel's vectors hold ``PACK_LANES // 2`` products on its two runs' lanes. Four float64: one 256-bit
register. Measured against eight (``/work/scratch_s8/parts.py``, a machine-local script; CPU, best
of 3000, load 2.6): B alone (2e-15, order 20) bianchiVI0_T3 10.3 us (4) against 12.5 (8), se2_T10
10.5 against 12.9, so4_T1 3.6 against 3.9-4.9; the pair 12.2 against 16.1, 12.8-13.7 against
14.5-14.9, 4.9 against 4.3.

Why it pays: at each order every product is a chain of ``k + 1`` dependent multiply-adds. With few
products (n = 3: twelve) the step is bound by that chain's latency, not by the multiply-adds' count,
so packing gains only what it saves around the chain (the order-``k`` operand from registers, the
first term before the loop); with many (so(4): 72) it is bound by their count and the loads, and
packing four to a vector cuts both (so4_T1 B alone 5.7 -> 3.6 us, su3_T1 13.0 -> 7.2)."""

PACK_LOOP = 8
"""Vectors of products summed side by side in one loop over ``a`` in the single kernel (one vector
accumulator each; the groups split into the fewest loops, sizes within one)."""

PAIR_LOOP = 12
"""The same for the pair kernel. Compile time of the pair kernel (what a first call compiles), so(5)
(330 vectors): 3.1 s at 8 per loop against 2.6 at 12 or more (7069b34's unpacked pair: 2.6-2.8);
runtime alike at 8, 12 and 16 within this machine's placement noise (the same machine code read
8.9-10.7 us on se3_T1 in fresh processes)."""


def spec(fs) -> tuple:
    """The structure of ``fs``'s recurrence as the literal ``SPEC`` of the order intrinsic
    (:func:`refimpl.codegen._full_state_ir.order_intrinsic`) and the kernel's rows: ``(SPEC, nv, VR,
    SR)`` with ``nv`` the rows of ``V``, ``VR`` the non-constant state rows, ``SR`` the step rows."""
    names, const = fs.names, fs.const
    idx = {v: i for i, v in enumerate(names)}
    dnames = [f"om{b}" for b in range(fs.n)] + [f"m{pa}_{k}_{j}" for (pa, k, j) in fs.mv]
    for v in dnames:
        idx[v] = len(idx)
    dconst = set()
    for b in range(fs.n):
        if all(p in const for _, p in fs.om[b]):
            dconst.add(f"om{b}")
    for (pa, k, j), t in fs.mv.items():
        if all(f"om{b}" in dconst for _, b in t):
            dconst.add(f"m{pa}_{k}_{j}")
    allconst = const | dconst
    # derived at order k: Omega_k, then M_k (rows in this order: M reads Omega)
    derived = [(idx[f"om{b}"], tuple((ci, idx[u]) for ci, u in fs.om[b])) for b in range(fs.n)]
    derived += [
        (idx[f"m{pa}_{k}_{j}"], tuple((ci, idx[f"om{b}"]) for ci, b in t))
        for (pa, k, j), t in fs.mv.items()
    ]
    prods: dict[tuple[str, str], int] = {}  # distinct pairs
    for v in names:
        for _, u, w in fs.quad[v]:
            prods.setdefault((u, w), len(prods))
    full = [
        (key, p) for key, p in prods.items() if key[0] not in allconst and key[1] not in allconst
    ]
    # products sharing their second factor side by side (see PRODUCT_CHUNK): same sums, fewer loads
    full.sort(key=lambda kp: (idx[kp[0][1]], idx[kp[0][0]]))
    chunks = tuple(
        tuple((p, idx[u], idx[w]) for (u, w), p in full[c0 : c0 + PRODUCT_CHUNK])
        for c0 in range(0, len(full), PRODUCT_CHUNK)
    )
    consts = []
    for (u, w), p in prods.items():
        cu, cw = u in allconst, w in allconst
        if cu or cw:
            consts.append(
                (
                    p,
                    idx[u],
                    idx[w],
                    ir.BOTH_CONST if cu and cw else ir.U_CONST if cu else ir.W_CONST,
                )
            )
    state = []
    for v in fs.var:
        terms = []
        for c, u, w in fs.quad[v]:
            p = prods[(u, w)]
            if isinstance(c, float):
                terms.append((ir.PLUS if c > 0 else ir.MINUS, 0, p))
            else:
                terms.append((ir.SCALED, c, p))
        for ci, u in fs.lin[v]:
            terms.append((ir.LIN_CONST if u in allconst else ir.LIN, ci, idx[u]))
        state.append((idx[v], tuple(terms)))
    sp = (len(fs.coef), tuple(derived), chunks, tuple(consts), tuple(state))
    return sp, len(idx), [idx[v] for v in fs.var], [idx[v] for v in fs.step_vars]


def full_state_source(fs) -> str:
    """The kernel module ``adaptive(y0, T, tol, P, max_steps, c, out, nsteps)`` for the structure of
    ``fs`` (a :class:`refimpl._full_state.FullState`)."""
    sp, nv, vrows, srows = spec(fs)
    I1, I2, I3, I4 = ("    " * i for i in range(1, 5))
    W, per_loop = PACK_LANES, PACK_LOOP
    ns1 = ir.pack_streams(sp, W, per_loop)

    def amax(k):  # max |V[row, k]| over the step rows: one loop over the table SR
        # order 0 as the run-time K0, not a literal: numba types a literal 0 as Literal[int] and
        # compiled _amax a second time for it (0.07-0.18 s cold)
        return f"_amax(V, SR, {'K0' if k == 0 else k})"

    step = adaptive_step_lines(amax, I1, "h > 0.0")
    # the compensated Horner update of every non-constant row (the intrinsic _update: the rows'
    # chains side by side)
    step += [
        "fin = _update(V, comp, hs, P)",
        "nst += 1",
        "if not fin:",
        I1 + "status = -1",
        I1 + "break",
        "if nst > max_steps:",
        I1 + "status = -3",
        I1 + "break",
    ]
    nvar = max(len(vrows), 1)
    src = [
        '"""Generated by tstarg.refimpl._full_state (one structure; numbers are arguments)."""',
        "import math",
        "import numpy as np",
        "from numba import njit",
        "from tstarg.refimpl.codegen import _full_state_ir",
        "",
        f"# the structure (refimpl.codegen.full_state.spec, IR version {ir.IR_VERSION}): ncoef,",
        "# derived rows, product chunks, products with a constant factor, state rows",
        f"SPEC = {sp!r}",
        f"_orders = _full_state_ir.order_intrinsic(SPEC, {W}, {per_loop}, True)",
        f"_load = _full_state_ir.load_intrinsic({sp[0]})",
        f"_update = _full_state_ir.update_intrinsic({tuple(vrows)!r})",
        f"_orders2 = _full_state_ir.lanes_order_intrinsic(SPEC, 2, {W // 2}, {PAIR_LOOP}, True)",
        f"_update2 = _full_state_ir.lane_update_intrinsic({tuple(vrows)!r}, 2)",
        "",
        "",
        _JIT,
        "def _amax(V, SR, k):",
        I1 + "m = 0.0",
        I1 + "for q in range(SR.shape[0]):",
        I2 + "m = max(m, abs(V[SR[q], k]))",
        I1 + "return m",
        "",
        "",
        _JIT,
        "def adaptive(y0, T, tol, P, max_steps, c, out, nsteps):",
        I1 + f"if c.shape[0] != {sp[0]} or y0.shape[1] != {fs.d} or P < 2:",
        I2 + "raise ValueError('adaptive: c, y0 or P do not fit the structure')",
        I1 + f"SR = np.array({srows}, dtype=np.int64)"
        if srows
        else I1 + "SR = np.zeros(0, dtype=np.int64)",
        I1 + "C = _load(c)",
        I1 + "N = y0.shape[0]",
        I1 + f"V = np.zeros(({nv}, P + 1))",
        I1 + f"B = np.empty(({ns1}, P + 1, {W}))",
        I1 + f"comp = np.zeros({nvar})",
        I1 + "sgn = 1.0 if T >= 0 else -1.0",
        I1 + "Tabs = abs(T)",
        I1 + "damp = math.exp(-0.7 / (P - 1))",
        I1 + "e1 = 1.0 / (P - 1)",
        I1 + "e2 = 1.0 / P",
        I1 + "K0 = np.int64(0)",
        I1 + "for it in range(N):",
        I2 + f"for q in range({fs.d}):",
        I3 + "V[q, 0] = y0[it, q]",
        I2 + f"for q in range({nvar}):",
        I3 + "comp[q] = 0.0",
        I2 + "t = 0.0",
        I2 + "nst = 0",
        I2 + "status = 0",
        I2 + "while t < Tabs:",
        I3 + "_orders(V, B, P, C)",
    ]
    src += [I3 + x for x in step]
    src += [
        I2 + f"for q in range({fs.d}):",
        I3 + "out[it, q] = V[q, 0] if status == 0 else np.nan",
        I2 + "nsteps[it] = nst if status == 0 else status",
    ]
    src += ["", ""] + pair_lines(fs, sp, nv, vrows, srows)
    # constants (derived) of order 0 are computed in the k = 0 pass; those are all we read of them
    return "\n".join(src) + "\n"


def pair_lines(fs, sp, nv: int, vrows: list, srows: list) -> list[str]:
    """The kernel ``pair(y0, T, tol_a, tol_b, P_a, P_b, max_steps, c, out, nsteps)``: the runs A
    (``tol_a``, order ``P_a``) and B (``tol_b``, ``P_b``) from the one start ``y0[0]`` side by side,
    as the two lanes of one vector (the order body
    :func:`refimpl.codegen._full_state_ir.lanes_order_intrinsic` on this kernel's own spec, its
    general products :data:`PACK_LANES` ``// 2`` to a vector of both lanes: each lane's operations
    those of :func:`order_intrinsic`), the series computed to ``max(P_a, P_b)`` for
    both; each lane its own step (from its order's last two coefficients), time, step count, carries
    and status, its Horner update to its own order (:func:`refimpl.codegen._full_state_ir.
    lane_update_intrinsic`, the single kernel's update on one lane) -- so lane A is the single kernel's run at
    ``(tol_a, P_a)`` and lane B at ``(tol_b, P_b)``, operation for operation. ``out[0]``, ``out[1]``:
    A's and B's end states, ``nsteps`` their steps (negative: the status, as :func:`adaptive`)."""
    I1, I2, I3, I4 = ("    " * i for i in range(1, 5))
    d = fs.d
    src = [
        _JIT,
        "def pair(y0, T, tol_a, tol_b, P_a, P_b, max_steps, c, out, nsteps):",
        I1 + f"if c.shape[0] != {sp[0]} or y0.shape[1] != {d} or min(P_a, P_b) < 2:",
        I2 + "raise ValueError('pair: c, y0 or the orders do not fit the structure')",
        I1 + f"SR = np.array({srows}, dtype=np.int64)"
        if srows
        else I1 + "SR = np.zeros(0, dtype=np.int64)",
        I1 + "C = _load(c)",
        I1 + "Pm = max(P_a, P_b)",
        I1 + f"V = np.zeros((Pm + 1, {nv}, 2))",
        I1
        + f"B = np.empty(({ir.pack_streams(sp, PACK_LANES // 2, PAIR_LOOP)}, Pm + 1, {PACK_LANES}))",
        I1 + f"comp = np.zeros(({max(len(vrows), 1)}, 2))",
        I1 + "PL = np.array([P_a, P_b], dtype=np.int64)",
        I1 + "tl = np.array([tol_a, tol_b])",
        I1 + "t = np.zeros(2)",
        I1 + "nst = np.zeros(2, dtype=np.int64)",
        I1 + "status = np.zeros(2, dtype=np.int64)",
        I1 + "live = np.ones(2, dtype=np.bool_)",
        I1 + "sgn = 1.0 if T >= 0 else -1.0",
        I1 + "Tabs = abs(T)",
        I1 + "for l in range(2):",
        I2 + f"for q in range({d}):",
        I3 + "V[0, q, l] = y0[0, q]",
        I2 + "if not (t[l] < Tabs):",
        I3 + "live[l] = False",
        I1 + "while live[0] or live[1]:",
        I2 + "_orders2(V, B, Pm, C)",
        I2 + "for l in range(2):",
        I3 + "if not live[l]:",
        I4 + "continue",
        I3 + "P = PL[l]",
        I3 + "xn = 0.0",
        I3 + "a1 = 0.0",
        I3 + "a2 = 0.0",
        I3 + "for q in range(SR.shape[0]):",
        I4 + "xn = max(xn, abs(V[0, SR[q], l]))",
        I3 + "for q in range(SR.shape[0]):",
        I4 + "a1 = max(a1, abs(V[P - 1, SR[q], l]))",
        I3 + "for q in range(SR.shape[0]):",
        I4 + "a2 = max(a2, abs(V[P, SR[q], l]))",
        I3 + "s = tl[l] * max(1.0, xn)",
        I3 + "h = np.inf",
        I3 + "if a1 > 0.0:",
        I4 + "h = (s / a1) ** (1.0 / (P - 1))",
        I3 + "if a2 > 0.0:",
        I4 + "h = min(h, (s / a2) ** (1.0 / P))",
        I3 + "h *= math.exp(-0.7 / (P - 1))",
        I3 + "if not (h > 0.0):",
        I4 + "status[l] = -4",
        I4 + "live[l] = False",
        I4 + "continue",
        I3 + "if t[l] + h >= Tabs:",
        I4 + "h = Tabs - t[l]",
        I4 + "t[l] = Tabs",
        I3 + "else:",
        I4 + "t[l] += h",
        I3 + "hs = sgn * h",
        I3 + "fin = _update2(V, comp, hs, P, l)",
        I3 + "nst[l] += 1",
        I3 + "if not fin:",
        I4 + "status[l] = -1",
        I4 + "live[l] = False",
        I3 + "elif nst[l] > max_steps:",
        I4 + "status[l] = -3",
        I4 + "live[l] = False",
        I3 + "elif not (t[l] < Tabs):",
        I4 + "live[l] = False",
        I1 + "for l in range(2):",
        I2 + f"for q in range({d}):",
        I3 + "out[l, q] = V[0, q, l] if status[l] == 0 else np.nan",
        I2 + "nsteps[l] = nst[l] if status[l] == 0 else status[l]",
    ]
    return src
