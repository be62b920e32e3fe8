"""The generated kernel of the compiled full state (:mod:`refimpl._full_state`), one per structure.

The source depends only on the structure of the field -- which variables exist, which are constant,
the nonzero patterns of ``I^-1``, ``f``, ``Theta``, ``G_L`` and of the representation's ``E_b`` --
and reads every number from one array ``c`` (locals ``c{i}`` loaded once per call). Per order ``k``:
the derived rows (``Omega_k``, then ``M_k = rho(Omega_k)``), the Cauchy products (independent sums
side by side, in generated helpers of :data:`HELPER_PRODUCTS` products: compile time), the state rows
from their terms. Step control and the
compensated Horner update as :mod:`refimpl._full_state_kernel` (the kernel compiled for every
structure, same recurrence; this one unrolls the products: about 2.2x faster per step).
"""

from __future__ import annotations

import re

from .rational import adaptive_step_lines
from .taylor import _JIT, tree_sum

__all__ = ["full_state_source"]


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
69 us). In each loop every distinct factor is read once per ``a`` into a local (numba types and
lowers one array index per factor instead of two per product: compile time, load 1.3-1.8, numba-warm:
the free so(5) top's 660 products 13.1 -> 9.9 s, free_su3 4.22 -> 3.57 s, kirchhoff_se3 1.86 ->
1.83 s; per step equal or better, interleaved, best of 100: free_su3 70.9 -> 63.5 us at ``2e-15``,
kirchhoff_se3 114.9 -> 113.1, manakov_so4 48.5 -> 48.2; the same multiply-adds in the same order)."""

DERIVED_TABLE_FROM = 64
"""Derived rows (``Omega_k``, the entries of ``M_k``) above this many are computed by one loop over a
table (target row, its terms' source rows and coefficient indices) instead of one generated line
each: the free so(5) top (adjoint representation) has 180, and each generated line costs numba
about 20 ms of compile time; a table costs a few ns of indirection per term, small beside the
products (su(2), su(3), se(3), so(4) stay unrolled: 6-30 rows).
Sums in the order of the terms (``a`` fixed), as the unrolled lines' trees up to rounding."""

HELPER_PRODUCTS = 64  # 0: all products in one helper
"""Cauchy products per generated helper function ``_prods{i}(V, k)`` (its chunk loops, returning the
sums as a tuple). numba's compile time grows faster than linearly with one function's size (its SSA
reconstruction and rewrites walk every variable over every block), so the products leave the kernel
in helpers of this many: the free so(5) top (adjoint representation, 660 products) compiled in 31 s
as one function and in 16 s so split (load 7; 4 to 64 products per helper within 1 s of each
other). Same arithmetic: each sum is accumulated in the order ``a = 0..k`` as before. No per-step
cost: free su(3) (140 products, three helpers), interleaved in one process, best of 200, CPU, load
1.6: kernel at ``eps = 2e-15``, order 22, 125.1 us split against 124.1 us as one function (32 per
helper: 121.4 us); the protocol flow 217.4 us against 223.4 us."""


def _sum(terms: list[str]) -> str:
    return tree_sum(terms) if terms else "0.0"


def full_state_source(fs) -> str:
    """The kernel module ``adaptive(y0, T, tol, P, max_steps, c, out, nsteps)`` for the structure of
    ``fs`` (a :class:`refimpl._full_state.FullState`)."""
    names, const = fs.names, fs.const
    idx = {v: i for i, v in enumerate(names)}
    dnames = [f"om{b}" for b in range(fs.n)] + [f"m{pa}_{k}_{j}" for (pa, k, j) in fs.mv]
    for v in dnames:
        idx[v] = len(idx)
    nv = len(idx)
    dconst = set()
    for b in range(fs.n):
        if all(p in const for _, p in fs.om[b]):
            dconst.add(f"om{b}")
    for (pa, k, j), t in fs.mv.items():
        if all(f"om{b}" in dconst for _, b in t):
            dconst.add(f"m{pa}_{k}_{j}")
    allconst = const | dconst

    def V(v, k):
        return f"V[{idx[v]}, {k}]"

    I1, I2, I3, I4, I5 = ("    " * i for i in range(1, 6))
    kb = []
    # derived at order k: Omega_k, then M_k (rows in this order: M reads Omega)
    derived = [(f"om{b}", list(fs.om[b])) for b in range(fs.n)]
    derived += [
        (f"m{pa}_{k}_{j}", [(ci, f"om{b}") for ci, b in t]) for (pa, k, j), t in fs.mv.items()
    ]
    tables = []
    if len(derived) > DERIVED_TABLE_FROM:  # one loop over a table (compile time), else unrolled
        dptr, dsrc, dci = [0], [], []
        for _, terms in derived:
            dsrc += [idx[u] for _, u in terms]
            dci += [ci for ci, _ in terms]
            dptr.append(len(dsrc))
        for name, vals in (
            ("DR", [idx[v] for v, _ in derived]),
            ("DP", dptr),
            ("DS", dsrc),
            ("DC", dci),
        ):
            tables.append(I1 + f"{name} = np.array([{', '.join(map(str, vals))}], dtype=np.int64)")
        kb += [
            "for ri in range(DR.shape[0]):",
            I1 + "dsum = 0.0",
            I1 + "for ti in range(DP[ri], DP[ri + 1]):",
            I2 + "dsum += c[DC[ti]] * V[DS[ti], k]",
            I1 + "V[DR[ri], k] = dsum",
        ]
    else:
        for v, terms in derived:
            kb.append(f"{V(v, 'k')} = " + _sum([f"c{ci} * {V(u, 'k')}" for ci, u in terms]))
    # products: distinct pairs
    prods: dict[tuple[str, str], str] = {}
    for v in names:
        for _, u, w in fs.quad[v]:
            key = (u, w)
            if key not in prods:
                prods[key] = f"p{len(prods)}"
    full = [
        (key, p) for key, p in prods.items() if key[0] not in allconst and key[1] not in allconst
    ]
    # products sharing their second factor side by side (see PRODUCT_CHUNK): same sums, fewer loads
    full.sort(key=lambda kp: (idx[kp[0][1]], idx[kp[0][0]]))
    helpers = []  # the general products, HELPER_PRODUCTS per generated function (compile time)
    per = HELPER_PRODUCTS or max(len(full), 1)
    for h, lo in enumerate(range(0, len(full), per)):
        part = full[lo : lo + per]
        hb = [_JIT, f"def _prods{h}(V, k):"] + [I1 + f"{p} = 0.0" for _, p in part]
        for c0 in range(
            0, len(part), PRODUCT_CHUNK
        ):  # independent sums side by side, a chunk per loop
            hb.append(I1 + "for a in range(k + 1):")
            # each distinct factor of the chunk read once per a (see PRODUCT_CHUNK)
            chunk = part[c0 : c0 + PRODUCT_CHUNK]
            hb.append(I2 + "b = k - a")
            fu = {u: f"fu{i}" for i, u in enumerate(dict.fromkeys(u for (u, _), _ in chunk))}
            fw = {w: f"fw{i}" for i, w in enumerate(dict.fromkeys(w for (_, w), _ in chunk))}
            hb += [I2 + f"{nm} = {V(u, 'a')}" for u, nm in fu.items()]
            hb += [I2 + f"{nm} = {V(w, 'b')}" for w, nm in fw.items()]
            hb += [I2 + f"{p} += {fu[u]} * {fw[w]}" for (u, w), p in chunk]
        names_h = ", ".join(p for _, p in part)
        hb += [I1 + f"return ({names_h},)", "", ""]
        helpers += hb
        kb.append(f"({names_h},) = _prods{h}(V, k)")
    for (u, w), p in prods.items():
        if u in allconst and w in allconst:
            kb.append(f"{p} = {V(u, 0)} * {V(w, 0)} if k == 0 else 0.0")
        elif u in allconst:
            kb.append(f"{p} = {V(u, 0)} * {V(w, 'k')}")
        elif w in allconst:
            kb.append(f"{p} = {V(u, 'k')} * {V(w, 0)}")
    kb.append("ik = 1.0 / (k + 1)")
    for v in fs.var:
        terms = []
        for c, u, w in fs.quad[v]:
            p = prods[(u, w)]
            if isinstance(c, float):
                terms.append(p if c > 0 else f"-{p}")
            else:
                terms.append(f"c{c} * {p}")
        for ci, u in fs.lin[v]:
            if u in allconst:
                terms.append(f"(c{ci} * {V(u, 0)} if k == 0 else 0.0)")
            else:
                terms.append(f"c{ci} * {V(u, 'k')}")
        kb.append(f"{V(v, 'k + 1')} = ({_sum(terms)}) * ik")

    rows = fs.step_vars

    def amax(k):  # max |V[row, k]| over the step rows: one loop over the table SR
        # order 0 as the run-time K0, not a literal: numba types a literal 0 as Literal[int] and
        # compiled _amax a second time for it (0.07-0.18 s cold)
        return f"_amax(V, SR, {'K0' if k == 0 else k})"

    step = adaptive_step_lines(amax, I1, "h > 0.0")
    # the compensated Horner update of every non-constant row: one loop over the table VR (a loop per
    # row would multiply the compile time, ~25 rows on su(3); same arithmetic in the same order)
    step += [
        "fin = True",
        "for ci in range(VR.shape[0]):",
        I1 + "i = VR[ci]",
        I1 + "z = V[i, P]",
        I1 + "for kk in range(P - 1, 0, -1):",
        I2 + "z = z * hs + V[i, kk]",
        I1 + "z = z * hs - comp[ci]",
        I1 + "w = V[i, 0] + z",
        I1 + "comp[ci] = (w - V[i, 0]) - z",
        I1 + "V[i, 0] = w",
        I1 + "if not math.isfinite(w):",
        I2 + "fin = False",
        "nst += 1",
        "if not fin:",
        I1 + "status = -1",
        I1 + "break",
        "if nst > max_steps:",
        I1 + "status = -3",
        I1 + "break",
    ]
    vr = ", ".join(str(idx[v]) for v in fs.var)
    sr = ", ".join(str(idx[v]) for v in rows)
    ncoef = len(fs.coef)
    src = [
        '"""Generated by tstarg.refimpl._full_state (one structure; numbers are arguments)."""',
        "import math",
        "import numpy as np",
        "from numba import njit",
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
        *helpers,
        _JIT,
        "def adaptive(y0, T, tol, P, max_steps, c, out, nsteps):",
        I1
        + (f"VR = np.array([{vr}], dtype=np.int64)" if vr else "VR = np.zeros(0, dtype=np.int64)"),
        I1
        + (f"SR = np.array([{sr}], dtype=np.int64)" if sr else "SR = np.zeros(0, dtype=np.int64)"),
    ]
    src += tables
    used = set(re.findall(r"\bc(\d+)\b", "\n".join(kb)))  # the table rows read c[...] directly
    src += [I1 + f"c{i} = c[{i}]" for i in range(ncoef) if str(i) in used]
    src += [
        I1 + "N = y0.shape[0]",
        I1 + f"V = np.zeros(({nv}, P + 1))",
        I1 + f"comp = np.zeros({max(len(fs.var), 1)})",
        I1 + "sgn = 1.0 if T >= 0 else -1.0",
        I1 + "Tabs = abs(T)",
        I1 + "damp = math.exp(-0.7 / (P - 1))",
        I1 + "e1 = 1.0 / (P - 1)",
        I1 + "e2 = 1.0 / P",
        I1 + "K0 = np.int64(0)",
        I1 + "for it in range(N):",
        I2 + f"for q in range({fs.d}):",
        I3 + "V[q, 0] = y0[it, q]",
        I2 + f"for q in range({max(len(fs.var), 1)}):",
        I3 + "comp[q] = 0.0",
        I2 + "t = 0.0",
        I2 + "nst = 0",
        I2 + "status = 0",
        I2 + "while t < Tabs:",
        I3 + "for k in range(P):",
    ]
    src += [I4 + x for x in kb]
    src += [I3 + x for x in step]
    src += [
        I2 + f"for q in range({fs.d}):",
        I3 + "out[it, q] = V[q, 0] if status == 0 else np.nan",
        I2 + "nsteps[it] = nst if status == 0 else status",
    ]
    del I5
    # constants (derived) of order 0 are computed in the k = 0 pass; those are all we read of them
    return "\n".join(src) + "\n"
