"""Generated compiled Taylor kernels for the quadratic fields (:mod:`refimpl._compiled_taylor`).

Emitters take a :class:`refimpl._compiled_taylor.CompiledField` ``cf`` (its *structure*: monomials,
their classes, the term pattern per component, the constant components -- never its numbers, which
are kernel arguments) and return module text, which :func:`refimpl.codegen._loader.import_source`
writes under the hash of the text and imports:

* :func:`loop_source` -- the template ``templates/taylor_loop.py`` (order an argument) with the
  structure's ``coefficients`` body (:func:`coefficient_source`);
* :func:`unrolled_source` -- ``adaptive``/``fixed`` unrolled at one order;
* :func:`batch_source` -- ``adaptive_batch``: the unrolled kernel on ``W`` lanes.
"""

from __future__ import annotations

import math

from . import _taylor_ir
from ._loader import fill, template

__all__ = [
    "BATCH_WIDTH",
    "batch_source",
    "chain_sum",
    "coefficient_source",
    "loop_source",
    "tree_sum",
    "unrolled_source",
]


def loop_source(cf) -> str:
    """The loop kernels (order an argument; template ``taylor_loop``) for the structure of ``cf``."""
    return fill(template("taylor_loop"), COEFF=coefficient_source(cf))


# ---------------------------------------------------------------- per-structure kernels
# The generic kernels below interpret the sparse arrays (one loop per term, branches per monomial). The
# fast path writes, once per *structure*, a small module whose loops are unrolled over the monomials and
# components (loops over the order stay loops: the order is an argument), with the coefficients read
# from the arrays ``q`` (quadratic terms) and ``l`` (linear terms). The module is a file in the cache
# directory named by the structure's hash, imported and compiled with ``cache=True``: the next process
# (or the next model with the same structure) loads machine code instead of compiling.


def coefficient_source(cf) -> str:
    """The unrolled body of ``coefficients(Y, P, q, l)`` for the structure of ``cf``."""
    d = cf.d
    ind = "    "
    src = [ind + f"y{c} = Y[{c}]" for c in range(d)]
    src.append(ind + "for k in range(P):")
    i2 = ind * 2
    i3 = ind * 3
    for m, ((i, j), c) in enumerate(zip(cf.mons.tolist(), cf.mcls.tolist())):
        if c == 0:
            src += [
                i2 + f"m{m} = 0.0",
                i2 + "for a in range(k + 1):",
                i3 + f"m{m} += y{i}[a] * y{j}[k - a]",
            ]
        elif c == 1:
            src += [
                i2 + f"m{m} = 0.0",
                i2 + "for a in range((k + 1) // 2):",
                i3 + f"m{m} += y{i}[a] * y{i}[k - a]",
                i2 + f"m{m} *= 2.0",
                i2 + "if k % 2 == 0:",
                i3 + f"m{m} += y{i}[k // 2] * y{i}[k // 2]",
            ]
        elif c == 2:
            src.append(i2 + f"m{m} = y{i}[0] * y{j}[k]")
        elif c == 3:
            src.append(i2 + f"m{m} = y{i}[k] * y{j}[0]")
        else:
            src.append(i2 + f"m{m} = y{i}[0] * y{j}[0] if k == 0 else 0.0")
    src.append(i2 + "inv = 1.0 / (k + 1)")
    for c in range(d):
        if cf.const[c]:
            src.append(i2 + f"y{c}[k + 1] = 0.0")
            continue
        terms = [f"q[{t}] * m{cf.qmon[t]}" for t in range(cf.qptr[c], cf.qptr[c + 1])]
        terms += [f"l[{t}] * y{cf.lidx[t]}[k]" for t in range(cf.lptr[c], cf.lptr[c + 1])]
        src.append(i2 + f"y{c}[k + 1] = ({' + '.join(terms) if terms else '0.0'}) * inv")
    return "\n".join(src)


def tree_sum(terms: list[str]) -> str:
    """``terms`` summed as a balanced binary tree, parenthesised: ``((a + b) + (c + d))``.

    A left-to-right chain ``a + b + c + ...`` is one dependency chain (each add waits for the one
    before, ~4 cycles each); the tree exposes independent adds to the CPU's parallel units
    without reassociation flags (``fastmath`` would also remove Kahan's compensation in
    :func:`unrolled_source`). Same rounding model: a sum of ``m`` terms, ``(log2 m) eps`` relative
    to the sum of magnitudes, no worse than the chain's ``(m - 1) eps``."""
    if len(terms) == 1:
        return terms[0]
    half = (len(terms) + 1) // 2
    return f"({tree_sum(terms[:half])} + {tree_sum(terms[half:])})"


def chain_sum(terms: list[str]) -> str:
    """``terms`` summed left to right, parenthesised: ``(a + b + c + d)``.

    With products as terms, LLVM contracts the chain into one multiply and ``m - 1`` fused
    multiply-adds (a tree needs ``m/2`` multiplies, ``m/2`` FMAs and ``m/2 - 1`` adds: half as many
    operations again). The chain is one dependency chain per sum, so it pays only where other
    independent work hides its latency: the lanes of :func:`batch_source` (the single-trajectory
    kernel keeps :func:`tree_sum`; measured in :func:`batch_source`). Rounding: ``(m - 1) eps`` relative to the sum of
    magnitudes, the textbook bound of recursive summation (Higham 2002, section 4.2)."""
    if len(terms) == 1:
        return terms[0]
    return "(" + " + ".join(terms) + ")"


# Unrolled kernels let LLVM fuse a multiply and an add into one FMA (``contract``: one rounding instead
# of two, never less accurate); no reassociation, so the compensated sums and the summation trees stay
# as written.
_JIT = "@njit(cache=True, nogil=True, fastmath={'contract'})"
_JIT1 = "@njit(cache=True, nogil=True, fastmath={'contract'}, _nrt=False)"
"""The decorator of :func:`unrolled_source`'s kernels: :data:`_JIT` without numba's reference counting
(``_nrt=False``, as numba's own allocation-free helpers use it): they allocate nothing, and with it
numba wrote a reference-count walk over every member of each tuple of the state and the ~10^2
coefficients at every use (a third of the su(2) pair kernel's IR, dead code LLVM then removed).
Measured (issue 25, the off-diagonal heavy top's order-16 module, fresh caches, load 5.6-5.8): the
pair's first call 3.15-3.53 -> 2.88-3.05 s, ``adaptive``'s 1.26-1.36 -> 0.94-1.09 s."""


def _kernel_prologue(cf, P: int) -> list[str]:
    """The first statements of an adaptive kernel: the field's numbers read once into locals, the
    batch size, the direction and length of the time span, the step's safety factor."""
    return _loads(cf) + [
        "N = y0.shape[0]",
        "sgn = 1.0 if T >= 0 else -1.0",
        "Tabs = abs(T)",
        f"damp = {math.exp(-0.7 / (P - 1))!r}",
    ]


def _loads(cf) -> list[str]:
    """The field's numbers read once per call into the tuples ``Q`` and ``L`` (the intrinsics' arguments)."""
    return [
        "Q = " + _tuple([f"q[{t}]" for t in range(len(cf.qcoef))]),
        "L = " + _tuple([f"l[{t}]" for t in range(len(cf.lcoef))]),
    ]


def _step_size_lines(
    P: int, xn: str, a1: str, a2: str, fail: list[str], tol: str = "tol"
) -> list[str]:
    """The Jorba-Zou step of the module docstring from the expressions of ``max|y_0|`` and of the last
    two coefficients' norms; ``fail`` runs when no positive step results (overflowed coefficients).

    ``min((s/a1)^(1/(P-1)), (s/a2)^(1/P))`` is taken as ``exp(min(log(s/a1)/(P-1), log(s/a2)/P))``
    (``exp`` and ``log`` increasing: the same step up to rounding): two logarithms and one exponential
    per step instead of two powers, 3 % of the heavy top's kernel time (order 15, A at 1e-6 and B at
    1e-13 over T = 100: 378.0 against 390.9 us, best of 30 interleaved, load 1.5). NaN (non-finite
    coefficients) still gives no positive step, ``a = 0`` no bound from that term."""
    return [
        f"s = {tol} * max(1.0, {xn})",
        f"a1 = {a1}",
        f"a2 = {a2}",
        "lh = np.inf",
        "if a1 > 0.0:",
        f"    lh = math.log(s / a1) * {1.0 / (P - 1)!r}",
        "if a2 > 0.0:",
        f"    lh = min(lh, math.log(s / a2) * {1.0 / P!r})",
        "h = math.exp(lh) * damp",
        "if not (h > 0.0):",
    ] + ["    " + x for x in fail]


def _tuple(items: list[str]) -> str:
    """A tuple display of ``items`` (``()``, ``(a,)``, ``(a, b)``)."""
    return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"


def _ir_header(cf, P: int) -> tuple[list[str], tuple]:
    """The generated module's imports and the structure of ``cf`` at order ``P`` as the literal
    ``SPEC`` of its intrinsics (:mod:`refimpl.codegen._taylor_ir`). Returns the lines and the spec."""
    sp = _taylor_ir.spec(cf, P)
    return [
        "import math",
        "import numpy as np",
        "from numba import njit",
        "from tstarg.refimpl.codegen import _taylor_ir",
        "",
        f"# the structure (refimpl.codegen._taylor_ir.spec, IR version {_taylor_ir.IR_VERSION}): d, P,",
        "# monomials, constant components, qptr, qmon, lptr, lidx",
        f"SPEC = {sp!r}",
    ], sp


PACK_WIDTH = 4
"""Lanes of one pack of Cauchy products in the one-trajectory and pair kernels
(:func:`refimpl.codegen._taylor_ir.pack_groups`: 4 monomials of one run, or 2 monomials of each of
the pair's two runs, in one AVX2 vector). Measured (issue 25, the asymmetric heavy top with an
off-diagonal inertia, T = 10, P = 16, wall-clock best of 1000, load 3.1-3.5; the one-run kernel at
1e-13 / the pair kernel): 2 lanes 35.1 / 38.4 us, 4 lanes 31.6 / 36.7, 8 lanes (AVX-512) 40.9 / 42.2;
the former kernel without packs 44.7-48.2 / 45.6-48.8 (one run's products one at a time)."""


def unrolled_source(cf, P: int) -> str:
    """A module with ``adaptive`` and ``fixed`` for the structure of ``cf`` at order ``P``, unrolled.

    The recurrence of :mod:`refimpl._compiled_taylor`'s docstring unrolled at order ``P`` (a square
    sums half its terms twice, a constant factor keeps its ``k = 0`` term; the Cauchy products in
    packs of :data:`PACK_WIDTH` lanes, each a chain of fused multiply-adds, the components' sums as
    balanced trees, :func:`tree_sum`), and the update ``y <- y + sum_{k>=1} Y_k h^k`` by Horner's rule added with
    Kahan's compensated summation (which keeps the rounding of ``10^3`` steps near one ulp instead of
    growing with the step count), are the intrinsics ``_coefs`` and ``_update`` of
    :mod:`refimpl.codegen._taylor_ir` (LLVM IR written directly: numba's front end would spend most of
    the compilation typing the ~10^4 operations one by one). The state, its carries and the
    coefficients are tuples of float64; the field's numbers are read once per call from ``q`` and ``l``
    into the tuples ``Q`` and ``L``. Same recurrence and control as the loop kernels of
    :func:`loop_source` (template ``taylor_loop``); only the summation order of a product may differ.
    """
    d = cf.d
    head, sp = _ir_header(cf, P)
    head += [
        f"_coefs = _taylor_ir.coefficients_intrinsic(SPEC, {PACK_WIDTH})",
        "_update = _taylor_ir.update_intrinsic(SPEC)",
        f"_coefs2 = _taylor_ir.lanes_coefficients_intrinsic(SPEC, 2, {PACK_WIDTH})",
        "_update2 = _taylor_ir.lanes_update_intrinsic(SPEC, 2)",
    ]
    var = _taylor_ir.variable_components(sp)
    unpack = [
        "Y = " + _tuple([f"y0[n, {c}]" for c in range(d)]),
        "E = " + _tuple(["0.0"] * len(var)),
    ]
    store_ok = [f"out[n, {c}] = Y[{c}]" for c in range(d)]
    I1, I2, I3, I4 = "    ", "        ", "            ", "                "
    src = head + ["", "", _JIT1, "def adaptive(y0, T, tol, max_steps, q, l, out, nsteps):"]
    src += [I1 + x for x in _kernel_prologue(cf, P)] + [I1 + "for n in range(N):"]
    src += [I2 + x for x in unpack]
    src += [I2 + "t = 0.0", I2 + "k = 0", I2 + "ok = True"]
    src += [I2 + x for x in _run_lines(P, var)]
    src += [I2 + "if ok:"] + [I3 + x for x in store_ok]
    src += [I2 + "else:", I3 + "for c in range(y0.shape[1]):", I4 + "out[n, c] = np.nan"]
    src += [
        I2 + "nsteps[n] = k if ok else -1",
        "",
        "",
        _JIT1,
        "def fixed(y0, h, nsteps, q, l, out):",
    ]
    src += [I1 + x for x in _loads(cf)]
    src += [I1 + "for n in range(y0.shape[0]):"] + [I2 + x for x in unpack]
    src += [
        I2 + "for _ in range(nsteps):",
        I3 + "Y, E = _update(Y, E, _coefs(Y, Q, L), h)",
    ]
    src += [I2 + x for x in store_ok]
    src += ["", "", _JIT1] + _pair_lines(cf, P, var)
    return "\n".join(src) + "\n"


def _run_lines(P: int, var: list[int], Y="Y", E="E", t="t", k="k", ok="ok", tol="tol") -> list[str]:
    """The loop of one run of the adaptive kernel (``_coefs``, ``_update``): the state ``Y`` and carries
    ``E`` at time ``t`` after ``k`` steps on to ``Tabs`` (direction ``sgn``) at the local tolerance
    ``tol``; ``ok`` False where it fails (a step not positive, a state not finite, over
    ``max_steps``). Written once for ``adaptive`` and the pair's run left over (each with its own
    names; the pair has one copy, for whichever run is left)."""
    I1, I2 = "    ", "        "
    K = len(var) * P
    fin = " and ".join(f"math.isfinite({Y}[{c}])" for c in var) or "True"
    src = [f"while {t} < Tabs:", I1 + f"C = _coefs({Y}, Q, L)"]
    src += [
        I1 + x
        for x in _step_size_lines(
            P, f"C[{K}]", f"C[{K + 1}]", f"C[{K + 2}]", [f"{ok} = False", "break"], tol=tol
        )
    ]
    src += [
        I1 + f"if {t} + h >= Tabs:",
        I2 + f"h = Tabs - {t}",
        I2 + f"{t} = Tabs",
        I1 + "else:",
        I2 + f"{t} += h",
        I1 + f"{Y}, {E} = _update({Y}, {E}, C, sgn * h)",
        I1 + f"{k} += 1",
        I1 + f"if not ({fin}) or {k} > max_steps:",
        I2 + f"{ok} = False",
        I2 + "break",
    ]
    return src


def _pair_lines(cf, P: int, var: list[int]) -> list[str]:
    """``pair(y0, T, tol_a, tol_b, max_steps, q, l, out_a, out_b, steps_a, steps_b)``: ``adaptive`` at
    the two local tolerances ``tol_a`` and ``tol_b`` from every row of ``y0`` at once: while both runs
    go on, on the lanes of one vector (the intrinsics ``_coefs2``, ``_update2``), each lane its own
    control, steps and carries, exactly as ``adaptive`` runs it; once one run reaches ``T`` (or
    fails), the other goes on alone on ``adaptive``'s own intrinsics (``_coefs``, ``_update``), from
    its state and carries as they are. Every lane of the packed recurrence computes what the one-run
    recurrence does (:func:`refimpl.codegen._taylor_ir.pack_groups`), so each run's steps and result
    are ``adaptive``'s at its tolerance, bit for bit. One pass over the trajectory instead of two
    while both run (the checking run's arithmetic rides in the answer's vector instructions), and
    the run left over (usually the answer, at the tighter tolerance) at the cost of one run."""
    d = cf.d
    nv = len(var)
    K = 2 * nv * P  # C[K:K + 3]: lane a's norms, C[K + 3:K + 6]: lane b's
    I1, I2, I3, I4, I5 = ("    " * i for i in range(1, 6))
    src = ["def pair(y0, T, tol_a, tol_b, max_steps, q, l, out_a, out_b, steps_a, steps_b):"]
    src += [I1 + x for x in _kernel_prologue(cf, P)] + [I1 + "for n in range(N):"]
    src += [
        I2 + "Y = " + _tuple([f"y0[n, {c}]" for c in range(d)] * 2),
        I2 + "E = " + _tuple(["0.0"] * (2 * nv)),
        I2 + "ta = 0.0",
        I2 + "tb = 0.0",
        I2 + "ka = 0",
        I2 + "kb = 0",
        I2 + "oka = True",
        I2 + "okb = True",
        I2 + "while ta < Tabs and tb < Tabs:",
        I3 + "C = _coefs2(Y, Q, L)",
    ]
    for x, off in (("a", 0), ("b", 3)):
        src += [
            I3 + x_
            for x_ in _step_size_lines(
                P,
                f"C[{K + off}]",
                f"C[{K + off + 1}]",
                f"C[{K + off + 2}]",
                [f"ok{x} = False", f"t{x} = Tabs", f"h{x} = 0.0"],
                tol=f"tol_{x}",
            )
        ]
        src += [
            I3 + "else:",
            I4 + f"if t{x} + h >= Tabs:",
            I4 + f"    h = Tabs - t{x}",
            I4 + f"    t{x} = Tabs",
            I4 + "else:",
            I4 + f"    t{x} += h",
            I4 + f"h{x} = sgn * h",
            I4 + f"k{x} += 1",
        ]
    src += [I3 + "Y, E = _update2(Y, E, C, (ha, hb))"]
    for x, off in (("a", 0), ("b", d)):
        fin = " and ".join(f"math.isfinite(Y[{off + c}])" for c in var) or "True"
        src += [
            I3 + f"if h{x} != 0.0 and (not ({fin}) or k{x} > max_steps):",
            I4 + f"ok{x} = False",
            I4 + f"t{x} = Tabs",
        ]
    # the run left over (at most one), alone on adaptive's loop from its lane's state and carries
    za = _tuple([f"Y[{c}]" for c in range(d)])
    fa = _tuple([f"E[{vi}]" for vi in range(nv)])
    zb = _tuple([f"Y[{d + c}]" for c in range(d)])
    fb = _tuple([f"E[{nv + vi}]" for vi in range(nv)])
    src += [
        I2 + "left = 1 if ta < Tabs else (2 if tb < Tabs else 0)",
        I2 + f"Z = {za}",
        I2 + f"F = {fa}",
        I2 + "if left != 0:",
        I3 + "t1, k1, tol1 = ta, ka, tol_a",
        I3 + "if left == 2:",
        I4 + f"Z = {zb}",
        I4 + f"F = {fb}",
        I4 + "t1, k1, tol1 = tb, kb, tol_b",
        I3 + "ok1 = True",
    ]
    src += [I3 + x for x in _run_lines(P, var, "Z", "F", "t1", "k1", "ok1", "tol1")]
    src += [
        I3 + "if left == 1:",
        I4 + "ka, oka = k1, ok1",
        I3 + "else:",
        I4 + "kb, okb = k1, ok1",
    ]
    for x, yo, w in (("a", 0, 1), ("b", d, 2)):
        src += [I2 + f"if ok{x} and left == {w}:"]
        src += [I3 + f"out_{x}[n, {c}] = Z[{c}]" for c in range(d)]
        src += [I2 + f"elif ok{x}:"]
        src += [I3 + f"out_{x}[n, {c}] = Y[{yo + c}]" for c in range(d)]
        src += [
            I2 + "else:",
            I3 + f"for c in range({d}):",
            I4 + f"out_{x}[n, c] = np.nan",
            I2 + f"steps_{x}[n] = k{x} if ok{x} else -1",
        ]
    return src


BATCH_WIDTH = (
    8  # lanes of the batch kernel: two AVX2 vectors of float64 (measured: see batch_source)
)


def batch_source(cf, P: int, W: int = BATCH_WIDTH) -> str:
    """A module with ``adaptive_batch(y0, T, tol, max_steps, q, l, out, nsteps)``: the adaptive kernel
    of :func:`unrolled_source` run on ``W`` trajectories side by side, one per *lane*.

    Every lane keeps its own time, step size (its own Jorba-Zou control from its own coefficients),
    step count and compensation carries, exactly as the single-trajectory kernel does; a lane whose
    trajectory reaches ``T`` (or fails) is refilled with the next trajectory, so no trajectory's
    steps are set by another's and no lane waits for the slowest. The lanes live in a flat scratch
    array ``B[row * W + w]`` (rows: state, carries, coefficients, norms, step); the recurrence and the
    update are one call each on all lanes, every row one vector of ``W`` float64
    (:func:`refimpl.codegen._taylor_ir.rows_coefficients_intrinsic`,
    :func:`refimpl.codegen._taylor_ir.rows_update_intrinsic`: each lane's operations those of the
    per-lane intrinsics, element by element); the step-size control and the bookkeeping stay scalar
    loops over the lanes. The former loop ``for w in range(W)`` over the per-lane intrinsics, left
    to LLVM's loop vectoriser, gave the same results (bitwise, /work/scratch_ir2/abt.py,
    machine-local) and cost more to compile and to run (fresh cache, wall best, load 2.4-2.6: heavy
    off-diagonal gyrostat at order 19 compile 3.9 -> 1.2 s, 5.3 -> 4.4 us per trajectory; order 11
    1.7 -> 0.9 s, 2.0 -> 1.85 us; Lagrange top order 19 0.88 -> 0.75 s, 2.27 -> 1.85 us).

    The Cauchy products and component sums are :func:`chain_sum` chains, not the single kernel's
    trees: the lanes already supply the independent work a tree exposes, and a chain is a third
    fewer operations (one FMA per term). So a trajectory's coefficients differ from the single
    kernel's by rounding only (``(m - 1) eps`` against ``(log2 m) eps`` relative to the magnitudes).
    Measured (heavy asymmetric top, order 15, 1000 trajectories, A at 1e-6 plus B at 1e-13 over T =
    100, interleaved, best of 4, load 3.6-4.5): W = 8 chains 128.5-129.1 us per trajectory against
    trees 140.0-142.3; chains at W = 4 / 16 134.4 / 132.5, trees 135.1 / 135.9; compilation the same
    (11.5 against 11.8 s).
    """
    d = cf.d
    head, sp = _ir_header(cf, P)
    var = _taylor_ir.variable_components(sp)
    nv = len(var)
    # rows of B
    RY = 0  # state, d rows
    RE = d  # Kahan carries, d rows (non-constant components only used)
    RC = 2 * d  # coefficients k = 1..P of the non-constant components: RC + vi * P + (k - 1)
    RX = RC + nv * P  # max |y_0|, then max |y_{P-1}|, max |y_P|
    RA1, RA2, RH = RX + 1, RX + 2, RX + 3
    R = RX + 4
    head += [
        f"_rows_coefficients = _taylor_ir.rows_coefficients_intrinsic(SPEC, {W}, {RY}, {RC})",
        f"_rows_update = _taylor_ir.rows_update_intrinsic(SPEC, {W}, {RY}, {RE}, {RC}, {RH})",
    ]

    def at(row):
        return f"B[{row * W} + w]"

    I1, I2, I3, I4, I5 = ("    " * i for i in range(1, 6))
    src = head + ["", "", _JIT, "def adaptive_batch(y0, T, tol, max_steps, q, l, out, nsteps):"]
    src += [I1 + x for x in _kernel_prologue(cf, P)]
    src += [
        I1 + f"B = np.zeros({R * W})",
        I1 + f"lane = np.full({W}, -1, dtype=np.int64)",
        I1 + f"tl = np.zeros({W})",
        I1 + f"kst = np.zeros({W}, dtype=np.int64)",
        I1 + f"bad = np.zeros({W}, dtype=np.bool_)",
        I1 + "nxt = 0",
        I1 + "active = 0",
        I1 + f"for w in range({W}):",
        I2 + "if nxt < N:",
        I3 + "lane[w] = nxt",
    ]
    src += [I3 + f"{at(RY + c)} = y0[nxt, {c}]" for c in range(d)]
    src += [I3 + "nxt += 1", I3 + "active += 1", I1 + "while active > 0:"]
    # 1. coefficients and norms, all lanes (SIMD)
    src += [I2 + "_rows_coefficients(B, Q, L)"]
    # 2. step sizes, per lane (scalar: logarithms and branches)
    src += [
        I2 + f"for w in range({W}):",
        I3 + f"{at(RH)} = 0.0",
        I3 + "if lane[w] < 0:",
        I4 + "continue",
    ]
    src += [
        I3 + x for x in _step_size_lines(P, at(RX), at(RA1), at(RA2), ["bad[w] = True", "continue"])
    ]
    src += [
        I3 + "if tl[w] + h >= Tabs:",
        I4 + "h = Tabs - tl[w]",
        I4 + "tl[w] = Tabs",
        I3 + "else:",
        I4 + "tl[w] += h",
        I3 + f"{at(RH)} = sgn * h",
    ]
    # 3. Horner and the compensated update, all lanes (SIMD)
    src += [I2 + "_rows_update(B)"]
    # 4. bookkeeping, per lane: a finished or failed trajectory is written out and its lane refilled
    fin = " and ".join(f"math.isfinite({at(RY + c)})" for c in var) or "True"
    src += [
        I2 + f"for w in range({W}):",
        I3 + "n = lane[w]",
        I3 + "if n < 0:",
        I4 + "continue",
        I3 + "if not bad[w]:",
        I4 + "kst[w] += 1",
        I3 + f"failed = bad[w] or not ({fin}) or kst[w] > max_steps",
        I3 + "if not failed and tl[w] < Tabs:",
        I4 + "continue",
        I3 + "if failed:",
        I4 + f"for c in range({d}):",
        I5 + "out[n, c] = np.nan",
        I4 + "nsteps[n] = -1",
        I3 + "else:",
    ]
    src += [I4 + f"out[n, {c}] = {at(RY + c)}" for c in range(d)]
    src += [
        I4 + "nsteps[n] = kst[w]",
        I3 + "tl[w] = 0.0",
        I3 + "kst[w] = 0",
        I3 + "bad[w] = False",
    ]
    src += [I3 + f"{at(RE + c)} = 0.0" for c in range(d)]
    src += [I3 + "if nxt < N:", I4 + "lane[w] = nxt"]
    src += [I4 + f"{at(RY + c)} = y0[nxt, {c}]" for c in range(d)]
    src += [I4 + "nxt += 1", I3 + "else:", I4 + "lane[w] = -1", I4 + "active -= 1"]
    src += [I4 + f"{at(RY + c)} = 0.0" for c in range(d)]
    return "\n".join(src) + "\n"
