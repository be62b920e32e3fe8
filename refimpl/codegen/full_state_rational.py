"""Generated kernel of the full state with ``Upsilon != 0`` on every algebra
(:mod:`refimpl._full_state_rational`), one per structure.

The module is the rational kernel of :mod:`refimpl.codegen.rational` -- the solve by ``Phi`` as a series
recurrence (:func:`refimpl.codegen.rational.solve_lines`: one inverse of ``Psi_0 = Phi_0^T`` per step,
``Omega_k``, ``pi_{k+1}``, ``Gamma_{k+1}`` per order) -- with the group element ``G = rho(g)`` of
:mod:`refimpl._full_state` riding along: per order ``k``

    ``M_k = rho(Omega_k)`` (``M_k[e] = sum c_i Omega_k[b]`` over the nonzero pattern of the ``E_b``),
    ``G_{k+1} = (1 / (k + 1)) sum_{a=0..k} G_a M_{k-a}``  (``dG/dt = G rho(Omega)``, vier10),
    ``s_{k+1} = P Omega_k / (k + 1)``  (the abelian part of ``x`` on exponential algebras).

The products are those of :class:`refimpl._full_state.FullState` (its ``quad`` rows of ``G``: complex
entries split into real and imaginary parts, a constant factor keeping its ``a = 0`` term only); the
source depends on the nonzero patterns only, every number is an array argument (``cfs``: the full
state's coefficient array). Step control (Jorba-Zou on ``pi``, ``Gamma`` and the varying entries of
``G``), the compensated update and the refusals (``status`` -1 non-finite, -2 degenerate set,
-3 step budget, -4 stalled step) are those of the su(2) rational kernel.
"""

from __future__ import annotations

from ._loader import template
from .rational import adaptive_step_lines, cauchy_loops, prologue_lines, solve_lines
from .taylor import tree_sum

__all__ = ["full_state_rational_source"]


def _int_array(name: str, values: list[int]) -> str:
    body = ", ".join(str(int(v)) for v in values)
    return (
        f"{name} = np.array([{body}], dtype=np.int64)"
        if values
        else f"{name} = np.zeros(0, dtype=np.int64)"
    )


def full_state_rational_source(rf, fs) -> str:
    """The kernel module ``adaptive(y0, T, tol, P, max_steps, fv, th, U, Ii, GL, UGL, cfs, cond_max, out,
    nsteps, tend, conds)`` for the structure of ``rf`` (a :class:`refimpl._compiled_rational.
    RationalField`) and ``fs`` (the :class:`refimpl._full_state.FullState` of the same model: the layout
    ``(pi, [Gamma,] G entries, [s])`` of ``y0`` and the ``G``/``s`` recurrences)."""
    n = rf.n
    grav = rf.gravity
    I1, I2, I3 = ("    " * i for i in range(1, 4))
    gnames = [f"g{p}_{i}_{j}" for p, i, j in fs.gvars]
    gidx = {g: v for v, g in enumerate(gnames)}
    mnames = [f"m{p}_{k}_{j}" for (p, k, j) in fs.mv]
    midx = {m: e for e, m in enumerate(mnames)}
    ab = [v for v in fs.names[fs.d - fs.n_ab :]] if fs.n_ab else []
    gvary = [g for g in gnames if g not in fs.const]
    used: set[int] = set()

    body, kb = solve_lines(rf, sensitivity=True, compact=True)
    # M_k = rho(Omega_k)
    for e, key in enumerate(fs.mv):
        terms = [f"c{ci} * OM[{b}, k]" for ci, b in fs.mv[key]]
        used.update(ci for ci, _ in fs.mv[key])
        kb.append(f"MM[{e}, k] = {tree_sum(terms)}")
    # the distinct products G[u] M[w]: general ones in one loop, a constant G factor at a = 0 only
    prods: dict[tuple[str, str], str] = {}
    for g in gvary:
        for _, u, w in fs.quad[g]:
            if (u, w) not in prods:
                prods[(u, w)] = f"gm{len(prods)}"
    full = [(key, p) for key, p in prods.items() if key[0] not in fs.const]
    if full:
        kb += [f"{p} = 0.0" for _, p in full]
        kb += cauchy_loops(
            "for a in range(k + 1):",
            [f"{p} += GG[{gidx[u]}, a] * MM[{midx[w]}, k - a]" for (u, w), p in full],
        )
    for (u, w), p in prods.items():
        if u in fs.const:
            kb.append(f"{p} = GG[{gidx[u]}, 0] * MM[{midx[w]}, k]")
    for g in gvary:
        terms = [prods[(u, w)] if c > 0 else f"-{prods[(u, w)]}" for c, u, w in fs.quad[g]]
        kb.append(f"GG[{gidx[g]}, k + 1] = ({tree_sum(terms)}) * ik")
    for ell, s in enumerate(ab):
        terms = []
        for ci, u in fs.lin[s]:
            used.add(ci)
            terms.append(f"c{ci} * OM[{int(u[2:])}, k]")
        kb.append(f"SS[{ell}, k + 1] = ({tree_sum(terms) if terms else '0.0'}) * ik")
    body += [I1 + x for x in kb]

    # the step norms and the compensated Horner update as loops over the blocks (a loop per row would
    # multiply the compile time; same arithmetic in the same order): PI, GA, the varying G (table GV), SS
    blocks = [("PI", "n", None, "0")]
    if grav:
        blocks.append(("GA", "n", None, "n"))
    blocks.append(("GG", "GV.shape[0]", "GV", "ncg"))
    blocks.append(("SS", str(len(ab)), None, "ncs"))
    norms = ["m0 = 0.0", "m1 = 0.0", "m2 = 0.0"]
    for arr, cnt, tab, _ in blocks[:-1]:
        norms += [f"for q in range({cnt}):", I1 + (f"i = {tab}[q]" if tab else "i = q")]
        norms += [
            I1 + f"m{j} = max(m{j}, abs({arr}[i, {k}]))" for j, k in enumerate(("0", "P - 1", "P"))
        ]
    step = norms + adaptive_step_lines(
        lambda k: {"0": "m0", "P - 1": "m1", "P": "m2"}[str(k)], I1, "h > stall * t"
    )
    step.append("fin = True")
    for arr, cnt, tab, off in blocks:
        step += [
            f"for q in range({cnt}):",
            I1 + (f"i = {tab}[q]" if tab else "i = q"),
            I1 + f"ci = {off} + q",
            I1 + f"z = {arr}[i, P]",
            I1 + "for kk in range(P - 1, 0, -1):",
            I2 + f"z = z * hs + {arr}[i, kk]",
            I1 + "z = z * hs - comp[ci]",
            I1 + f"w = {arr}[i, 0] + z",
            I1 + f"comp[ci] = (w - {arr}[i, 0]) - z",
            I1 + f"{arr}[i, 0] = w",
            I1 + "if not math.isfinite(w):",
            I2 + "fin = False",
        ]
    step += [
        "nst += 1",
        "if not fin:",
        I1 + "status = -1",
        I1 + "break",
        "if nst > max_steps:",
        I1 + "status = -3",
        I1 + "break",
    ]
    nrows = n * (2 if grav else 1) + len(gvary) + len(ab)

    io = [("PI", a) for a in range(n)] + ([("GA", a) for a in range(n)] if grav else [])
    io += [("GG", v) for v in range(len(gnames))] + [("SS", ell) for ell in range(len(ab))]
    src = [
        template("rational_header"),
        "",
        "@njit(cache=True, nogil=True)",
        "def adaptive(y0, T, tol, P, max_steps, fv, th, U, Ii, GL, UGL, cfs, cond_max, out, nsteps, tend, conds):",
    ]
    pro = prologue_lines(rf, nrows)
    src += pro[:-1]
    src += [I1 + f"c{ci} = cfs[{ci}]" for ci in sorted(used)]
    src += [
        I1 + f"GG = np.zeros(({max(len(gnames), 1)}, P + 1))",
        I1 + f"MM = np.zeros(({max(len(mnames), 1)}, P + 1))",
        I1 + f"SS = np.zeros(({max(len(ab), 1)}, P + 1))",
        I1 + _int_array("GV", [gidx[g] for g in gvary]),
        I1 + _int_array("TRM", [t[0] for t in rf.trip]),
        I1 + _int_array("TRA", [t[1] for t in rf.trip]),
        I1 + _int_array("TRB", [t[2] for t in rf.trip]),
        I1 + f"ncg = {n * (2 if grav else 1)}",
        I1 + f"ncs = {n * (2 if grav else 1) + len(gvary)}",
        I1 + "unorm = 0.0",
        I1 + "for a in range(n):",
        I2 + "unorm = max(unorm, np.sum(np.abs(U[a])))",
        pro[-1],
    ]
    for col, (r, i) in enumerate(io):
        src.append(I2 + f"{r}[{i}, 0] = y0[it, {col}]")
    src += [
        I2 + f"for q in range({nrows}):",
        I3 + "comp[q] = 0.0",
        I2 + "t = 0.0",
        I2 + "nst = 0",
        I2 + "status = 0",
        I2 + "cond_seen = 0.0",
        I2 + "while t < Tabs:",
    ]
    src += [I3 + x for x in body]
    src += [I3 + x for x in step]
    for col, (r, i) in enumerate(io):
        src.append(I2 + f"out[it, {col}] = {r}[{i}, 0]")
    src += [
        I2 + "nsteps[it] = nst if status == 0 else status",
        I2 + "tend[it] = sgn * t",
        I2 + "conds[it] = cond_seen",
    ]
    return "\n".join(src) + "\n"
