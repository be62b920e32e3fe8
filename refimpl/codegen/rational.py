"""Generated compiled Taylor kernels for the rational body fields (``Upsilon != 0``;
:mod:`refimpl._compiled_rational`).

:func:`kernel_source` takes a :class:`refimpl._compiled_rational.RationalField` and writes, from its
*structure* only (the dimension, the nonzero patterns of ``f``, ``I^-1``, ``Upsilon``, ``Theta``,
``G_L`` and ``Upsilon G_L``, gravity, the quaternion), a module: the head ``templates/rational_header.py``
(Gauss-Jordan inversion, the starting Gamma) and the adaptive series recurrence of the solve by Phi,
with the numbers as arguments and the order an argument.
"""

from __future__ import annotations

import numpy as np

from ._loader import template

__all__ = [
    "STALL",
    "adaptive_step_lines",
    "amax_of",
    "cauchy_loops",
    "kernel_source",
    "prologue_lines",
    "sensitivity_lines",
    "solve_lines",
    "update_lines",
]

STALL = 64 * float(np.finfo(float).eps)  # a step below STALL * t cannot advance t reliably: stalled


def _matvec(name: str, mask: np.ndarray, vec: str, transpose: bool = False) -> list[list[str]]:
    """Per output row ``a``: the terms ``name[a, b] * vec(b)`` over the nonzero pattern ``mask``."""
    n = mask.shape[0]
    rows = []
    for a in range(n):
        terms = []
        for b in range(n):
            nz = mask[b, a] if transpose else mask[a, b]
            if nz:
                idx = f"{b}, {a}" if transpose else f"{a}, {b}"
                terms.append(f"{name}[{idx}] * {vec.format(b)}")
        rows.append(terms)
    return rows


def _levi(a: int, b: int, c: int) -> int:
    """The Levi-Civita symbol eps_abc (0-based indices)."""
    return (a - b) * (b - c) * (c - a) // 2


def _sum(terms) -> str:
    return " + ".join(terms) if terms else "0.0"


CHUNK = 16
"""Accumulators per Cauchy loop (:func:`cauchy_loops`): more sums side by side than this spill out of
the registers and multiply the compile time (LLVM's register allocation on one long loop body)."""


def cauchy_loops(head: str, lines: list[str]) -> list[str]:
    """The accumulation ``lines`` under the loop ``head``, in loops of at most :data:`CHUNK` lines
    (one loop when they fit: the kernels of few pairs, su(2)'s, are unchanged)."""
    out = []
    for i in range(0, len(lines), CHUNK):
        out.append(head)
        out += ["    " + x for x in lines[i : i + CHUNK]]
    return out


def sensitivity_lines(mi: str, s0: str, unorm: str) -> list[str]:
    """``cnd = ||Psi_0^-1||_inf (1 + ||S_0||_inf ||Upsilon||_inf)`` where ``cnd`` is finite: the
    sensitivity of the solve by ``Phi`` to the data (docs/conventions.md), which sees ``Delta -> 0``
    where the condition number alone cannot (``Phi = (1 - u s) 1`` on 2-dimensional algebras);
    at least ``cond_inf(Psi_0)`` since ``||Psi_0|| <= 1 + ||Upsilon|| ||S_0||``."""
    I1, I2, I3 = ("    " * i for i in range(1, 4))
    return [
        "if cnd < np.inf:",
        I1 + "mn = 0.0",
        I1 + "sn = 0.0",
        I1 + "for a in range(n):",
        I2 + "ra = 0.0",
        I2 + "sa = 0.0",
        I2 + "for b in range(n):",
        I3 + f"ra += abs({mi}[a, b])",
        I3 + f"sa += abs({s0}[a, b])",
        I2 + "mn = max(mn, ra)",
        I2 + "sn = max(sn, sa)",
        I1 + f"cnd = mn * (1.0 + sn * {unorm})",
    ]


def solve_lines(
    rf, sensitivity: bool = False, compact: bool = False
) -> tuple[list[str], list[str]]:
    """The solve by ``Phi`` as a series recurrence, shared by every rational kernel: ``(per_step,
    per_order)``. ``per_step`` (inside the step loop): ``S_0``, ``Psi_0 = 1 + Upsilon S_0``, its inverse
    ``Mi`` and condition (``status = -2`` and stop above ``cond_max``), then the line
    ``for k in range(P):``; ``per_order`` (the body of that loop, unindented): ``Omega_k`` into ``OM``,
    ``pi_{k+1}`` into ``PI`` and ``Gamma_{k+1}`` into ``GA``, ``ik = 1 / (k + 1)`` set. Arrays and
    locals as :func:`prologue_lines` allocates them."""
    n = rf.n
    trip = rf.trip
    nzI = rf.Iinv != 0.0
    nzU = rf.U != 0.0
    nzT = rf.theta != 0.0
    nzG = rf.GL != 0.0
    nzUG = rf.UGL != 0.0
    grav = rf.gravity
    I1, I2, I3 = ("    " * i for i in range(1, 4))

    # pairs of the contractions: (S v)_a <- (m, b); (S^T w)_b <- (m, a); Gdot_mu <- (Omega b, Gamma m)
    sv_pairs = sorted({(m, b) for m, a, b in trip})
    st_pairs = sorted({(m, a) for m, a, b in trip})
    g_pairs = sorted({(a, m) for m, a, b in trip})

    def contract(prefix, out_of, pair_of):
        rows = [[] for _ in range(n)]
        for t, (m, a, b) in enumerate(trip):
            p = pair_of(m, a, b)
            rows[out_of(m, a, b)].append(f"fv{t} * {prefix}_{p[0]}_{p[1]}")
        return rows

    body = []
    # ---- Psi_0 = 1 + U S_0 and its inverse; the condition number
    if compact:  # S_0 by loops over the index tables TRM, TRA, TRB (the caller defines them)
        body += [
            "for a in range(n):",
            I1 + "for b in range(n):",
            I2 + "S0[a, b] = -th[a, b]",
            "for e in range(TRM.shape[0]):",
            I1 + "S0[TRA[e], TRB[e]] += fv[e] * PI[TRM[e], 0]",
        ]
    for a in range(n if not compact else 0):
        for b in range(n):
            terms = [
                f"fv{t} * PI[{m}, 0]" for t, (m, aa, bb) in enumerate(trip) if (aa, bb) == (a, b)
            ]
            if nzT[a, b]:
                terms.append(f"- th[{a}, {b}]")
            body.append(f"S0[{a}, {b}] = {_sum(terms).replace('+ -', '-')}")
    body += [
        "for a in range(n):",
        I1 + "for b in range(n):",
        I2 + "acc = 1.0 if a == b else 0.0",
        I2 + "for c in range(n):",
        I3 + "acc += U[a, c] * S0[c, b]",
        I2 + "Psi[a, b] = acc",
        "cnd = invert(Psi, Mi, n, GJ)",
    ]
    if sensitivity:
        body += sensitivity_lines("Mi", "S0", "unorm")
    body += [
        "if not (cnd <= cond_max):",
        I1 + "status = -2",
        I1 + "cond_seen = cnd",
        I1 + "break",
        "cond_seen = max(cond_seen, cnd)",
        "for k in range(P):",
    ]
    # ---- order k
    kb = []
    # Omega_k: r = Iinv pi_k + UGL Gamma_k - U (sum_{j=1..k} S_j Omega_{k-j})
    kb += [f"po_{m}_{b} = 0.0" for m, b in sv_pairs]
    kb += cauchy_loops(
        "for j in range(1, k + 1):",
        [f"po_{m}_{b} += PI[{m}, j] * OM[{b}, k - j]" for m, b in sv_pairs],
    )
    cso = contract("po", lambda m, a, b: a, lambda m, a, b: (m, b))
    kb += [f"cs{a} = {_sum(cso[a])}" for a in range(n)]
    rI = _matvec("Ii", nzI, "PI[{}, k]")
    rG = _matvec("UGL", nzUG, "GA[{}, k]") if grav else [[] for _ in range(n)]
    rU = _matvec("U", nzU, "cs{}")
    for a in range(n):
        terms = rI[a] + rG[a]
        e = _sum(terms)
        if rU[a]:
            e += " - (" + " + ".join(rU[a]) + ")"
        kb.append(f"r{a} = {e}")
    for a in range(n):
        kb.append(f"OM[{a}, k] = " + _sum([f"Mi[{a}, {b}] * r{b}" for b in range(n)]))
    # dK_k = Iinv pi_k
    for a in range(n):
        kb.append(f"DK[{a}, k] = {_sum(rI[a])}")
    # sum_{j=0..k} S_j dK_{k-j} (f part) and sum_{j=1..k} S_j^T w_{k-j}
    kb += [f"pd_{m}_{b} = PI[{m}, 0] * DK[{b}, k]" for m, b in sv_pairs]
    kb += [f"pw_{m}_{a} = 0.0" for m, a in st_pairs]
    kb += cauchy_loops(
        "for j in range(1, k + 1):",
        [f"pd_{m}_{b} += PI[{m}, j] * DK[{b}, k - j]" for m, b in sv_pairs]
        + [f"pw_{m}_{a} += PI[{m}, j] * W[{a}, k - j]" for m, a in st_pairs],
    )
    csd = contract("pd", lambda m, a, b: a, lambda m, a, b: (m, b))
    csw = contract("pw", lambda m, a, b: b, lambda m, a, b: (m, a))
    rTh = _matvec("th", nzT, "DK[{}, k]")
    rGL = _matvec("GL", nzG, "GA[{}, k]") if grav else [[] for _ in range(n)]
    for a in range(n):
        pos = rGL[a] + rTh[a]  # G_L Gamma_k + Theta dK_k
        neg = csd[a] + csw[a]
        e = _sum(pos)
        if neg:
            e += " - (" + " + ".join(neg) + ")"
        kb.append(f"q{a} = {e}")
    inv = "ik"
    kb.append(f"{inv} = 1.0 / (k + 1)")
    for a in range(n):
        kb.append(f"pd{a} = " + _sum([f"Mi[{b}, {a}] * q{b}" for b in range(n)]))
    for a in range(n):
        kb.append(f"PI[{a}, k + 1] = pd{a} * {inv}")
    wU = _matvec("U", nzU, "pd{}", transpose=True)
    for a in range(n):
        kb.append(f"W[{a}, k] = {_sum(wU[a])}")
    if grav:
        kb += [f"og_{b}_{m} = 0.0" for b, m in g_pairs]
        kb += cauchy_loops(
            "for j in range(k + 1):",
            [f"og_{b}_{m} += OM[{b}, j] * GA[{m}, k - j]" for b, m in g_pairs],
        )
        cg = contract("og", lambda m, a, b: b, lambda m, a, b: (a, m))
        for mu in range(n):
            kb.append(f"GA[{mu}, k + 1] = ({_sum(cg[mu])}) * {inv}")
    return body, kb


def update_lines(rows: list[tuple[str, object]]) -> list[str]:
    """After :func:`adaptive_step_lines`: the compensated Horner update of every row ``(array, index)``
    (``comp[c]`` the compensation of row ``c``), the finiteness check (``status = -1``) and the step
    budget (``status = -3``)."""
    I1 = "    "
    step = []
    for c, (r, i) in enumerate(rows):
        step += [
            f"z = {r}[{i}, P]",
            "for kk in range(P - 1, 0, -1):",
            I1 + f"z = z * hs + {r}[{i}, kk]",
            f"z = z * hs - comp[{c}]",
            f"w = {r}[{i}, 0] + z",
            f"comp[{c}] = (w - {r}[{i}, 0]) - z",
            f"{r}[{i}, 0] = w",
        ]
    fin = " and ".join(f"math.isfinite({r}[{i}, 0])" for r, i in rows)
    step += [
        "nst += 1",
        f"if not ({fin}):",
        I1 + "status = -1",
        I1 + "break",
        "if nst > max_steps:",
        I1 + "status = -3",
        I1 + "break",
    ]
    return step


def amax_of(rows: list[tuple[str, object]]):
    """``amax(k)``: the expression of ``max_c |rows_c[k]|`` (for :func:`adaptive_step_lines`)."""

    def amax(k):
        e = f"abs({rows[0][0]}[{rows[0][1]}, {k}])"
        for r, c in rows[1:]:
            e = f"max({e}, abs({r}[{c}, {k}]))"
        return e

    return amax


def prologue_lines(rf, ncomp: int) -> list[str]:
    """The kernel's first lines after its ``def``: the dimension, the loaded ``fv{t}``, the work
    arrays of :func:`solve_lines` (``QQ`` the su(2) quaternion's), ``ncomp`` compensations and the
    step constants, ending with ``for it in range(N):``."""
    I1 = "    "
    src = [I1 + f"n = {rf.n}"]
    src += [I1 + f"fv{t} = fv[{t}]" for t in range(len(rf.trip))]
    src += [
        I1 + "N = y0.shape[0]",
        I1 + "PI = np.zeros((n, P + 1))",
        I1 + "GA = np.zeros((n, P + 1))",
        I1 + "OM = np.zeros((n, P + 1))",
        I1 + "DK = np.zeros((n, P + 1))",
        I1 + "W = np.zeros((n, P + 1))",
        I1 + "QQ = np.zeros((4, P + 1))",
        I1 + "S0 = np.zeros((n, n))",
        I1 + "Psi = np.zeros((n, n))",
        I1 + "Mi = np.zeros((n, n))",
        I1 + "GJ = np.zeros((n, 2 * n))",
        I1 + f"comp = np.zeros({ncomp})",
        I1 + "sgn = 1.0 if T >= 0 else -1.0",
        I1 + "Tabs = abs(T)",
        I1 + "damp = math.exp(-0.7 / (P - 1))",
        I1 + "e1 = 1.0 / (P - 1)",
        I1 + "e2 = 1.0 / P",
        I1 + f"stall = {STALL!r}",
        I1 + "for it in range(N):",
    ]
    return src


def kernel_source(rf) -> str:
    """The kernel module for the structure of ``rf`` (see the module docstring)."""
    n, d = rf.n, rf.d
    grav = rf.gravity
    I1, I2, I3 = ("    " * i for i in range(1, 4))
    inv = "ik"
    body, kb = solve_lines(rf)
    if rf.quat:
        # the group element as the unit quaternion q (g = q_0 - i q.sigma, refimpl._taylor.
        # quadratic_field_su2_full): dq/dt = q * (0, Omega/2), i.e. dq_0/dt = -1/2 q.Omega and
        # dq/dt = 1/2 (q_0 Omega + q x Omega); bilinear in (q, Omega): Cauchy products with OM
        qb = ["for j in range(k + 1):"]
        kb += [f"qo_{i}_{b} = 0.0" for i in range(4) for b in range(n)]
        kb += qb + [
            I1 + f"qo_{i}_{b} += QQ[{i}, j] * OM[{b}, k - j]" for i in range(4) for b in range(n)
        ]
        kb.append(
            f"QQ[0, k + 1] = -0.5 * ({' + '.join(f'qo_{b + 1}_{b}' for b in range(n))}) * {inv}"
        )
        for a in range(n):
            cross = []
            for e in range(n):
                for b in range(n):
                    sgn = _levi(a, e, b)
                    if sgn:
                        cross.append(f"{'+' if sgn > 0 else '-'} qo_{e + 1}_{b}")
            kb.append(f"QQ[{a + 1}, k + 1] = 0.5 * (qo_0_{a} {' '.join(cross)}) * {inv}")
    body += [I1 + x for x in kb]

    rows = [("PI", c) for c in range(n)] + ([("GA", c) for c in range(n)] if grav else [])
    if rf.quat:
        rows += [("QQ", c) for c in range(4)]

    # no step (the coefficients overflowed) or a step collapsed below float64's resolution of t:
    # a real singularity of the field ahead (vier12); the caller checks the state is finite
    step = adaptive_step_lines(amax_of(rows), I1, "h > stall * t")
    step += update_lines(rows)

    src = [
        template("rational_header"),
        "",
        "@njit(cache=True, nogil=True)",
        "def adaptive(y0, T, tol, P, max_steps, fv, th, U, Ii, GL, UGL, cond_max, out, nsteps, tend, conds):",
    ]
    src += prologue_lines(rf, d)
    for c, (r, i) in enumerate(rows):
        src.append(I2 + f"{r}[{i}, 0] = y0[it, {c}]")
    src += [
        I2 + f"for c in range({d}):",
        I3 + "comp[c] = 0.0",
        I2 + "t = 0.0",
        I2 + "nst = 0",
        I2 + "status = 0",
        I2 + "cond_seen = 0.0",
        I2 + "while t < Tabs:",
    ]
    src += [I3 + x for x in body]
    src += [I3 + x for x in step]
    for c, (r, i) in enumerate(rows):
        src.append(I2 + f"out[it, {c}] = {r}[{i}, 0]")
    src += [
        I2 + "nsteps[it] = nst if status == 0 else status",
        I2 + "tend[it] = sgn * t",
        I2 + "conds[it] = cond_seen",
    ]
    return "\n".join(src) + "\n"


def adaptive_step_lines(amax, I1: str, accept: str) -> list[str]:
    """The Jorba-Zou step of :mod:`refimpl._compiled_taylor` (from ``max|y_0|`` and the norms of the
    last two coefficients, ``amax(k)`` the expression of ``max_c |Y_{k,c}|``) with the time
    bookkeeping of the adaptive loops: ``status = -4`` and stop unless ``accept`` holds, the last step
    clipped to ``Tabs``, ``hs`` the signed step. Shared by the rational and the full-state kernels."""
    return [
        f"s = tol * max(1.0, {amax(0)})",
        f"a1 = {amax('P - 1')}",
        f"a2 = {amax('P')}",
        "h = np.inf",
        "if a1 > 0.0:",
        I1 + "h = (s / a1) ** e1",
        "if a2 > 0.0:",
        I1 + "h = min(h, (s / a2) ** e2)",
        "h *= damp",
        f"if not ({accept}):",
        I1 + "status = -4",
        I1 + "break",
        "if t + h >= Tabs:",
        I1 + "h = Tabs - t",
        I1 + "t = Tabs",
        "else:",
        I1 + "t += h",
        "hs = sgn * h",
    ]
