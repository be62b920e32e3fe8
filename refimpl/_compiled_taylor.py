"""Compiled (numba) Taylor kernels for quadratic polynomial fields, fixed-step and adaptive.

What is compiled
    One machine-code kernel for *every* quadratic field ``ydot_c = sum_m Q_cm u_m(y) + sum_i
    Lin_ci y_i`` with monomials ``u_m = y_i y_j`` (:class:`refimpl._taylor.QuadraticField`): the
    field's structure (dimension, monomial list, which terms are present, constant components) and
    its numbers (``f``, ``Theta``, ``I``, ``L``, ``gamma`` folded into ``Q`` and ``Lin``) are array
    *arguments* in a sparse (CSR) form, never literals. numba therefore compiles each kernel once per
    argument type signature -- once in total for float64 -- and ``cache=True`` stores the machine code
    on disk so that a second process loads it instead of compiling (:func:`compile_count` reports the
    signatures compiled in this process).

The recurrence (Jorba and Zou 2005, Experimental Mathematics 14, 99-117)
    With ``y(t0 + s) = sum_k Y_k s^k`` (unscaled Taylor coefficients, ``Y_0 = y(t0)``) the
    coefficients of a product are the Cauchy product, so

        Y_{k+1,c} = 1/(k+1) * ( sum_m Q_cm sum_{a=0}^{k} Y_{a,i_m} Y_{k-a,j_m} + sum_i Lin_ci Y_{k,i} ),

    exact (no truncation). A constant component (identically zero field) keeps ``Y_{k>=1} = 0``, so
    a Cauchy product with a constant factor has the single term ``a = 0``; a square sums half the
    terms twice. ``y(t0 + h) ~ sum_{k<=P} Y_k h^k`` by Horner's rule.

Adaptive order and step (Jorba and Zou 2005, section 3.2; the control heyoka uses)
    For a tolerance ``eps`` Jorba and Zou take the order ``P = ceil(-ln(eps)/2 + 1)`` (the default here
    adds :data:`ORDER_BIAS`, measured cheaper for these kernels: :func:`default_order`), and with the scale
    ``s = max(1, ||y||_inf)`` (absolute error control below 1, relative above) the step is

        h = exp(-0.7 / (P - 1)) * min( (eps s / ||Y_{P-1}||_inf)^(1/(P-1)), (eps s / ||Y_P||_inf)^(1/P) ),

    (with the Jorba-Zou order ``eps^(1/P) ~ e^-2``, their ``rho / e^2``; written with ``eps`` so that
    a caller-chosen order keeps the tolerance), which makes the last terms of the series, an estimate of the remainder, about ``eps * s``
    (a local error per step). Each trajectory of a batch runs its own control (its own steps),
    so no trajectory's step is set by another's; the global error is checked by the callers
    (:func:`refimpl._flow_fast.fast_flow` compares two tolerances).

Without numba (``HAVE_NUMBA`` False) the same functions run as plain Python (slow but exact same
arithmetic); :data:`PATH` says which path ran.
"""

from __future__ import annotations

import hashlib
import importlib
import math
import os
import sys
from pathlib import Path

import numpy as np

try:  # numba is a core dependency; the plain-Python path keeps the package usable without it
    import numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is missing
    numba = None
    HAVE_NUMBA = False

__all__ = [
    "HAVE_NUMBA",
    "PATH",
    "CompiledField",
    "adaptive_order",
    "compile_count",
    "compiled_field",
    "taylor_adaptive",
    "taylor_fixed",
]

PATH = "numba" if HAVE_NUMBA else "python"


class CompiledField:
    """The sparse arrays of a quadratic field (kernel arguments; see the module docstring)."""

    __slots__ = (
        "_key",
        "_kernels",
        "const",
        "d",
        "lcoef",
        "lidx",
        "lptr",
        "mcls",
        "mons",
        "qcoef",
        "qmon",
        "qptr",
    )

    def __init__(self, F):
        self._kernels: dict = {}
        d = F.d
        mons = F.monomials()
        slot = {ij: m for m, ij in enumerate(mons)}
        const = F.constant_components()
        self.d = d
        self.mons = np.array(mons, dtype=np.int64).reshape(-1, 2)
        # monomial class: 0 general, 1 square, 2 first factor constant, 3 second constant, 4 both constant
        cls = []
        for i, j in mons:
            if i in const and j in const:
                cls.append(4)
            elif i in const:
                cls.append(2)
            elif j in const:
                cls.append(3)
            else:
                cls.append(1 if i == j else 0)
        self.mcls = np.array(cls, dtype=np.int64)
        qptr, qmon, qcoef, lptr, lidx, lcoef = [0], [], [], [0], [], []
        for c in range(d):
            for ij, q in F.quad[c].items():
                qmon.append(slot[ij])
                qcoef.append(q)
            qptr.append(len(qmon))
            for i, q in F.lin[c].items():
                lidx.append(i)
                lcoef.append(q)
            lptr.append(len(lidx))
        self.qptr = np.array(qptr, dtype=np.int64)
        self.qmon = np.array(qmon, dtype=np.int64)
        self.qcoef = np.array(qcoef, dtype=float)
        self.lptr = np.array(lptr, dtype=np.int64)
        self.lidx = np.array(lidx, dtype=np.int64)
        self.lcoef = np.array(lcoef, dtype=float)
        self.const = np.array([c in const for c in range(d)], dtype=np.bool_)

    def structure_key(self) -> tuple:
        """What decides the generated code (never the numbers): monomials, their classes, the term
        pattern per component, the constant components."""
        if getattr(self, "_key", None) is None:
            self._key = self._structure()
        return self._key

    def _structure(self) -> tuple:
        return (
            self.d,
            self.mons.tobytes(),
            self.mcls.tobytes(),
            self.qptr.tobytes(),
            self.qmon.tobytes(),
            self.lptr.tobytes(),
            self.lidx.tobytes(),
            self.const.tobytes(),
        )

    def args(self):
        return (
            self.mons,
            self.mcls,
            self.qptr,
            self.qmon,
            self.qcoef,
            self.lptr,
            self.lidx,
            self.lcoef,
            self.const,
        )


def compiled_field(F) -> CompiledField:
    return CompiledField(F)


def adaptive_order(tol: float) -> int:
    """Jorba-Zou order for a tolerance: ``P = ceil(-ln(tol)/2 + 1)``, at least 2."""
    return max(2, math.ceil(-math.log(tol) / 2.0 + 1.0))


# ---------------------------------------------------------------- per-structure kernels
# The generic kernels below interpret the sparse arrays (one loop per term, branches per monomial). The
# fast path writes, once per *structure*, a small module whose loops are unrolled over the monomials and
# components (loops over the order stay loops: the order is an argument), with the coefficients read
# from the arrays ``q`` (quadratic terms) and ``l`` (linear terms). The module is a file in the cache
# directory named by the structure's hash, imported and compiled with ``cache=True``: the next process
# (or the next model with the same structure) loads machine code instead of compiling.
_TEMPLATE = """
import math
import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def coefficients(Y, P, q, l):
{COEFF}


@njit(cache=True, nogil=True)
def horner(Y, P, h):
    for c in range(Y.shape[0]):
        s = Y[c, P]
        for k in range(P - 1, -1, -1):
            s = s * h + Y[c, k]
        Y[c, 0] = s


@njit(cache=True, nogil=True)
def fixed(y0, h, nsteps, P, q, l, out):
    N, d = y0.shape
    Y = np.zeros((d, P + 1))
    for n in range(N):
        for c in range(d):
            Y[c, 0] = y0[n, c]
        for _ in range(nsteps):
            coefficients(Y, P, q, l)
            horner(Y, P, h)
        for c in range(d):
            out[n, c] = Y[c, 0]


@njit(cache=True, nogil=True)
def adaptive(y0, T, tol, P, max_steps, q, l, out, nsteps):
    N, d = y0.shape
    Y = np.zeros((d, P + 1))
    sgn = 1.0 if T >= 0 else -1.0
    Tabs = abs(T)
    damp = math.exp(-0.7 / (P - 1))
    e1 = 1.0 / (P - 1)
    e2 = 1.0 / P
    for n in range(N):
        for c in range(d):
            Y[c, 0] = y0[n, c]
        t = 0.0
        k = 0
        ok = True
        while t < Tabs:
            coefficients(Y, P, q, l)
            xn = 0.0
            a1 = 0.0
            a2 = 0.0
            for c in range(d):
                xn = max(xn, abs(Y[c, 0]))
                a1 = max(a1, abs(Y[c, P - 1]))
                a2 = max(a2, abs(Y[c, P]))
            s = tol * max(1.0, xn)
            h = np.inf
            if a1 > 0.0:
                h = (s / a1) ** e1
            if a2 > 0.0:
                h = min(h, (s / a2) ** e2)
            h *= damp
            if not (h > 0.0):
                ok = False
                break
            if t + h >= Tabs:
                h = Tabs - t
                t = Tabs
            else:
                t += h
            horner(Y, P, sgn * h)
            k += 1
            fin = True
            for c in range(d):
                if not math.isfinite(Y[c, 0]):
                    fin = False
            if not fin or k > max_steps:
                ok = False
                break
        for c in range(d):
            out[n, c] = Y[c, 0] if ok else np.nan
        nsteps[n] = k if ok else -1
"""


def _coefficient_source(cf: CompiledField) -> str:
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


def cache_dir() -> Path:
    """Where the per-structure kernel modules live: ``$TSTARG_CACHE_DIR`` or ``~/.cache/tstarg``."""
    root = os.environ.get("TSTARG_CACHE_DIR") or os.path.join(
        os.path.expanduser("~"), ".cache", "tstarg"
    )
    return Path(root) / "taylor_kernels"


_MODULES: dict = {}


def tree_sum(terms: list[str]) -> str:
    """``terms`` summed as a balanced binary tree, parenthesised: ``((a + b) + (c + d))``.

    A left-to-right chain ``a + b + c + ...`` is one dependency chain (each add waits for the one
    before, ~4 cycles each); the tree exposes independent adds to the CPU's parallel units
    without reassociation flags (``fastmath`` would also remove Kahan's compensation in
    :func:`_unrolled_source`). Same rounding model: a sum of ``m`` terms, ``(log2 m) eps`` relative
    to the sum of magnitudes, no worse than the chain's ``(m - 1) eps``."""
    if len(terms) == 1:
        return terms[0]
    half = (len(terms) + 1) // 2
    return f"({tree_sum(terms[:half])} + {tree_sum(terms[half:])})"


# Unrolled kernels let LLVM fuse a multiply and an add into one FMA (``contract``: one rounding instead
# of two, never less accurate); no reassociation, so the compensated sums and the summation trees stay
# as written.
_JIT = "@njit(cache=True, nogil=True, fastmath={'contract'})"


def _coefficient_lines(cf: CompiledField, P: int) -> tuple[list[str], list[int]]:
    """Straight-line statements computing the Taylor coefficients ``y{c}_{k}``, ``k = 1..P``, from the
    locals ``y{c}_0`` (the recurrence of the module docstring, unrolled; sums as balanced trees), and the
    non-constant components."""
    d = cf.d
    const = set(np.flatnonzero(cf.const).tolist())
    mons = [tuple(m) for m in cf.mons.tolist()]

    def z(c, k):
        return k >= 1 and c in const

    body = []
    for k in range(P):
        for m, (i, j) in enumerate(mons):
            if i == j:
                terms = [
                    f"y{i}_{a}*y{i}_{k - a}"
                    for a in range((k + 1) // 2)
                    if not z(i, a) and not z(i, k - a)
                ]
                expr = f"2.0*{tree_sum(terms)}" if terms else ""
                if k % 2 == 0 and not z(i, k // 2):
                    expr = (expr + " + " if expr else "") + f"y{i}_{k // 2}*y{i}_{k // 2}"
            else:
                terms = [
                    f"y{i}_{a}*y{j}_{k - a}"
                    for a in range(k + 1)
                    if not z(i, a) and not z(j, k - a)
                ]
                expr = tree_sum(terms) if terms else ""
            body.append(f"m{m} = {expr or '0.0'}")
        for c in range(d):
            if c in const:
                continue
            terms = [f"q{t}*m{cf.qmon[t]}" for t in range(cf.qptr[c], cf.qptr[c + 1])]
            terms += [
                f"l{t}*y{cf.lidx[t]}_{k}"
                for t in range(cf.lptr[c], cf.lptr[c + 1])
                if not z(int(cf.lidx[t]), k)
            ]
            body.append(f"y{c}_{k + 1} = {tree_sum(terms) if terms else '0.0'}*{1.0 / (k + 1)!r}")
    return body, [c for c in range(d) if c not in const]


def _kernel_prologue(cf: CompiledField, P: int) -> list[str]:
    """The first statements of an adaptive kernel: the field's numbers read once into locals, the
    batch size, the direction and length of the time span, the step's safety factor."""
    return _loads(cf) + [
        "N = y0.shape[0]",
        "sgn = 1.0 if T >= 0 else -1.0",
        "Tabs = abs(T)",
        f"damp = {math.exp(-0.7 / (P - 1))!r}",
    ]


def _loads(cf: CompiledField) -> list[str]:
    """The field's numbers read once per call into locals ``q{t}``, ``l{t}``."""
    return [f"q{t} = q[{t}]" for t in range(len(cf.qcoef))] + [
        f"l{t} = l[{t}]" for t in range(len(cf.lcoef))
    ]


def _step_size_lines(P: int, xn: str, a1: str, a2: str, fail: list[str]) -> list[str]:
    """The Jorba-Zou step of the module docstring from the expressions of ``max|y_0|`` and of the last
    two coefficients' norms; ``fail`` runs when no positive step results (overflowed coefficients)."""
    return [
        f"s = tol * max(1.0, {xn})",
        f"a1 = {a1}",
        f"a2 = {a2}",
        "h = np.inf",
        "if a1 > 0.0:",
        f"    h = (s / a1) ** {1.0 / (P - 1)!r}",
        "if a2 > 0.0:",
        f"    h = min(h, (s / a2) ** {1.0 / P!r})",
        "h *= damp",
        "if not (h > 0.0):",
    ] + ["    " + x for x in fail]


def _unrolled_source(cf: CompiledField, P: int) -> str:
    """A module with ``adaptive`` and ``fixed`` for the structure of ``cf`` at order ``P``, unrolled.

    Every coefficient is a local scalar ``y{c}_{k}``; the Cauchy products are written out (a square
    sums half its terms twice, a constant factor keeps its ``k = 0`` term) and the field's numbers
    are read once per call from ``q`` and ``l`` into locals. Same recurrence and control as the loop
    kernels of :data:`_TEMPLATE`; only the summation order of a product may differ, and the update
    ``y <- y + sum_{k>=1} Y_k h^k`` is a compensated (Kahan) sum, which keeps the rounding of ``10^3``
    steps near one ulp instead of growing with the step count.
    """
    d = cf.d
    body, var = _coefficient_lines(cf, P)

    def horner(hname):
        # increment sum_{k>=1} Y_k h^k by Horner, added to y with Kahan's compensated summation (the
        # carry e{c} keeps the low-order bits lost in y + increment: no drift of rounding over many steps)
        out = []
        for c in var:
            e = f"y{c}_{P}"
            for k in range(P - 1, 0, -1):
                e = f"({e})*{hname} + y{c}_{k}"
            out += [
                f"z = ({e})*{hname} - e{c}",
                f"w = y{c}_0 + z",
                f"e{c} = (w - y{c}_0) - z",
                f"y{c}_0 = w",
            ]
        return out

    def amax(k):
        terms = [f"abs(y{c}_{k})" for c in (range(d) if k == 0 else var)]
        if not terms:
            return "0.0"
        e = terms[0]
        for t in terms[1:]:  # pairwise max: numba's variadic max builds a tuple per call
            e = f"max({e}, {t})"
        return e

    load = _kernel_prologue(cf, P)
    unpack = [f"y{c}_0 = y0[n, {c}]" for c in range(d)] + [f"e{c} = 0.0" for c in var]
    store_ok = [f"out[n, {c}] = y{c}_0" for c in range(d)]
    fin = " and ".join(f"math.isfinite(y{c}_0)" for c in var) or "True"
    I1, I2, I3, I4 = "    ", "        ", "            ", "                "
    src = [
        "import math",
        "import numpy as np",
        "from numba import njit",
        "",
        "",
        _JIT,
        "def adaptive(y0, T, tol, max_steps, q, l, out, nsteps):",
    ]
    src += [I1 + x for x in load]
    src += [I1 + "for n in range(N):"]
    src += [I2 + x for x in unpack]
    src += [I2 + "t = 0.0", I2 + "k = 0", I2 + "ok = True", I2 + "while t < Tabs:"]
    src += [I3 + x for x in body] + [I3 + "pass"]
    src += [
        I3 + x for x in _step_size_lines(P, amax(0), amax(P - 1), amax(P), ["ok = False", "break"])
    ]
    src += [
        I3 + "if t + h >= Tabs:",
        I4 + "h = Tabs - t",
        I4 + "t = Tabs",
        I3 + "else:",
        I4 + "t += h",
        I3 + "hs = sgn * h",
    ]
    src += [I3 + x for x in horner("hs")]
    src += [
        I3 + "k += 1",
        I3 + f"if not ({fin}) or k > max_steps:",
        I4 + "ok = False",
        I4 + "break",
    ]
    src += [I2 + "if ok:"] + [I3 + x for x in store_ok]
    src += [I2 + "else:", I3 + "for c in range(y0.shape[1]):", I4 + "out[n, c] = np.nan"]
    src += [
        I2 + "nsteps[n] = k if ok else -1",
        "",
        "",
        _JIT,
        "def fixed(y0, h, nsteps, q, l, out):",
    ]
    src += [I1 + x for x in _loads(cf)]
    src += [I1 + "for n in range(y0.shape[0]):"] + [I2 + x for x in unpack]
    src += (
        [I2 + "for _ in range(nsteps):"]
        + [I3 + x for x in body]
        + [I3 + x for x in horner("h")]
        + [I3 + "pass"]
    )
    src += [I2 + x for x in store_ok]
    return "\n".join(src) + "\n"


BATCH_MIN = 64  # trajectories from which taylor_adaptive runs the batch kernel by default
BATCH_WIDTH = 8  # lanes of the batch kernel: two AVX2 vectors of float64 (measured: 4, 8 and 16 within noise of each other)


def _batch_source(cf: CompiledField, P: int, W: int = BATCH_WIDTH) -> str:
    """A module with ``adaptive_batch(y0, T, tol, max_steps, q, l, out, nsteps)``: the adaptive kernel
    of :func:`_unrolled_source` run on ``W`` trajectories side by side, one per *lane*.

    Every lane keeps its own time, step size (its own Jorba-Zou control from its own coefficients),
    step count and compensation carries, exactly as the single-trajectory kernel does; a lane whose
    trajectory reaches ``T`` (or fails) is refilled with the next trajectory, so no trajectory's
    steps are set by another's and no lane waits for the slowest. The per-lane work is written as
    loops ``for w in range(W)`` over a flat scratch array ``B[row * W + w]`` (rows: state, carries,
    coefficients, norms, step), which LLVM turns into SIMD instructions across the lanes (the single
    kernel's arithmetic, statement for statement, on W trajectories at once); the step-size
    control and the bookkeeping stay scalar.
    """
    d = cf.d
    body, var = _coefficient_lines(cf, P)
    nv = len(var)
    # rows of B
    RY = 0  # state, d rows
    RE = d  # Kahan carries, d rows (non-constant components only used)
    RC = 2 * d  # coefficients k = 1..P of the non-constant components: RC + vi * P + (k - 1)
    RX = RC + nv * P  # max |y_0|
    RA1, RA2, RH = RX + 1, RX + 2, RX + 3
    R = RX + 4

    def at(row):
        return f"B[{row * W} + w]"

    def amax(names):
        if not names:
            return "0.0"
        e = f"abs({names[0]})"
        for t in names[1:]:
            e = f"max({e}, abs({t}))"
        return e

    I1, I2, I3, I4, I5 = ("    " * i for i in range(1, 6))
    load = _kernel_prologue(cf, P)
    src = ["import math", "import numpy as np", "from numba import njit", "", "", _JIT]
    src.append("def adaptive_batch(y0, T, tol, max_steps, q, l, out, nsteps):")
    src += [I1 + x for x in load]
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
    src.append(I2 + f"for w in range({W}):")
    src += [I3 + f"y{c}_0 = {at(RY + c)}" for c in range(d)]
    src += [I3 + x for x in body]
    for vi, c in enumerate(var):
        src += [I3 + f"{at(RC + vi * P + k - 1)} = y{c}_{k}" for k in range(1, P + 1)]
    src += [
        I3 + f"{at(RX)} = {amax([f'y{c}_0' for c in range(d)])}",
        I3 + f"{at(RA1)} = {amax([f'y{c}_{P - 1}' for c in var])}",
        I3 + f"{at(RA2)} = {amax([f'y{c}_{P}' for c in var])}",
    ]
    # 2. step sizes, per lane (scalar: powers and branches)
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
    src += [I2 + f"for w in range({W}):", I3 + f"hs = {at(RH)}"]
    for vi, c in enumerate(var):
        e = at(RC + vi * P + P - 1)
        for k in range(P - 1, 0, -1):
            e = f"({e})*hs + {at(RC + vi * P + k - 1)}"
        src += [
            I3 + f"z = ({e})*hs - {at(RE + c)}",
            I3 + f"y = {at(RY + c)}",
            I3 + "v = y + z",
            I3 + f"{at(RE + c)} = (v - y) - z",
            I3 + f"{at(RY + c)} = v",
        ]
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


MAX_UNROLLED_ORDER = 30  # beyond this the loop kernels of _TEMPLATE run (order an argument)
UNROLL_BUDGET = (
    4500  # unrolled Cauchy-product terms (monomials * P(P+1)/2) above which the loop kernel
)
# runs instead: LLVM's compile time grows with the straight-line code (a heavy top's full state at order 20
# has about 4200 and compiles in ~2 s; larger structures would take tens of seconds once)


def _unrolls(cf: CompiledField, order) -> bool:
    return (
        order is not None
        and order <= MAX_UNROLLED_ORDER
        and len(cf.mons) * order * (order + 1) // 2 <= UNROLL_BUDGET
    )


def _import_kernel_module(src: str):
    """Write ``src`` once into the cache directory under its hash and import it (numba then caches the
    machine code beside it)."""
    key = hashlib.sha1(src.encode()).hexdigest()[:20]
    if key in _MODULES:
        return _MODULES[key]
    folder = cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"taylor_{key}.py"
    if (
        not path.exists() or path.read_text() != src
    ):  # never rewrite an existing file: numba keys on mtime
        tmp = folder / f".taylor_{key}.{os.getpid()}.tmp"
        tmp.write_text(src)
        os.replace(tmp, path)
    # an importable module (numba's disk cache re-imports the module by name when loading machine code)
    if str(folder) not in sys.path:
        sys.path.append(str(folder))
    mod = importlib.import_module(f"taylor_{key}")
    _MODULES[key] = mod
    return mod


def structure_kernels(cf: CompiledField, order: int | None = None):
    """The compiled module for the structure of ``cf``: unrolled at ``order`` (``adaptive(y0, T, tol,
    max_steps, q, l, out, nsteps)``, ``fixed(y0, h, nsteps, q, l, out)``) when ``order`` is given and at
    most :data:`MAX_UNROLLED_ORDER`, else the loop kernels (order an argument). None without numba."""
    if not HAVE_NUMBA:
        return None
    skey = (cf.structure_key(), order if _unrolls(cf, order) else None)
    if skey in _BY_STRUCTURE:
        return _BY_STRUCTURE[skey]
    _BY_STRUCTURE[skey] = mod = _structure_module(cf, order)
    return mod


_BY_STRUCTURE: dict = {}


def batch_kernels(cf: CompiledField, order: int):
    """The compiled batch module (:func:`_batch_source`) for the structure of ``cf`` at ``order``
    (unrolled structures only; None without numba)."""
    if not HAVE_NUMBA or not _unrolls(cf, order):
        return None
    skey = (cf.structure_key(), int(order), "batch", BATCH_WIDTH)
    if skey not in _BY_STRUCTURE:
        _BY_STRUCTURE[skey] = _import_kernel_module(_batch_source(cf, int(order)))
    return _BY_STRUCTURE[skey]


def _structure_module(cf: CompiledField, order):
    if _unrolls(cf, order):
        return _import_kernel_module(_unrolled_source(cf, int(order)))
    return _import_kernel_module(_TEMPLATE.replace("{COEFF}", _coefficient_source(cf)))


def taylor_fixed(cf: CompiledField, y0, h: float, nsteps: int, order: int) -> np.ndarray:
    """``nsteps`` Taylor steps of order ``order`` and size ``h`` for every row of ``y0`` (N, d)."""
    y = np.ascontiguousarray(y0, dtype=float)
    out = np.empty_like(y)
    order = int(order)
    mod = structure_kernels(cf, order)
    if mod is not None and _unrolls(cf, order):
        mod.fixed(y, float(h), int(nsteps), cf.qcoef, cf.lcoef, out)
    elif mod is not None:
        mod.fixed(y, float(h), int(nsteps), order, cf.qcoef, cf.lcoef, out)
    else:
        _py_fixed(cf, y, float(h), int(nsteps), int(order), out)
    return out


def taylor_adaptive(
    cf: CompiledField,
    y0,
    T: float,
    tol: float,
    order: int | None = None,
    max_steps: int = 10_000_000,
    batch: bool | None = None,
):
    """Adaptive Taylor over ``[0, T]`` for every row of ``y0`` (N, d): ``(y(T), steps)``.

    ``batch``: run the SIMD batch kernel (:func:`_batch_source`, same arithmetic per trajectory, about
    2.5x the throughput) -- by default when ``N >= BATCH_MIN`` (its one-off compilation, 3-5 s per
    structure and order before the disk cache has it, is then repaid); it needs the unrolled kernels.

    ``order`` defaults to :func:`default_order` of ``tol``; ``steps[n] = -1`` marks a trajectory that
    became non-finite or exceeded ``max_steps`` (its row is NaN; callers raise naming it).
    """
    P = default_order(cf, tol) if order is None else int(order)
    y = np.ascontiguousarray(y0, dtype=float)
    out = np.empty_like(y)
    steps = np.zeros(y.shape[0], dtype=np.int64)
    kern = cf._kernels.get(P)  # per field and order: the module and whether it is unrolled
    if kern is None:
        kern = cf._kernels[P] = (structure_kernels(cf, P), _unrolls(cf, P))
    mod, unrolled = kern
    if batch is None:
        batch = y.shape[0] >= BATCH_MIN
    if mod is not None and unrolled and batch and T != 0:
        bkey = ("batch", P)
        bmod = cf._kernels.get(bkey)
        if bmod is None:
            bmod = cf._kernels[bkey] = batch_kernels(cf, P)
        bmod.adaptive_batch(y, float(T), float(tol), int(max_steps), cf.qcoef, cf.lcoef, out, steps)
    elif mod is not None and unrolled:
        mod.adaptive(y, float(T), float(tol), int(max_steps), cf.qcoef, cf.lcoef, out, steps)
    elif mod is not None:
        mod.adaptive(y, float(T), float(tol), P, int(max_steps), cf.qcoef, cf.lcoef, out, steps)
    else:
        _py_adaptive(cf, y, float(T), float(tol), P, int(max_steps), out, steps)
    return out, steps


ORDER_BIAS = 3
"""Orders above Jorba and Zou's ``ceil(-ln(tol)/2 + 1)`` that the default order adds. Their optimum
assumes a step costs ~P^2 serial multiply-adds; the unrolled kernels sum each Cauchy product as a
balanced tree with fused multiply-adds, so a step's cost grows more slowly with the order, and higher
orders buy longer steps for less. Measured (work-precision against a long-double heyoka reference,
T = 100 / 100 / 100, errors 1e-6, 1e-9, 1e-12, time at equal error relative to bias 0): heavy top
0.67 / 0.74 / 0.84, asymmetric heavy top 0.85 / 0.83 / 0.96, free asymmetric top 0.81 / 0.80 / 0.87;
bias 4 and 6 were no better on the asymmetric top. The step-size rule keeps its meaning at any
order (the last two terms of the series ~ ``tol`` times the scale)."""


def default_order(cf: CompiledField, tol: float) -> int:
    """The order :func:`taylor_adaptive` runs when none is given: Jorba-Zou's plus :data:`ORDER_BIAS`,
    lowered (never below Jorba-Zou's) while the structure would leave the unrolled kernels."""
    P0 = adaptive_order(tol)
    P = P0 + ORDER_BIAS
    while P > P0 and not _unrolls(cf, P):
        P -= 1
    return P


def compile_count() -> dict:
    """Kernels of this process by outcome: ``compiled`` (machine code made here), ``loaded`` (from the
    disk cache), ``structures`` (distinct field structures seen). numba path only (zeros otherwise)."""
    out = {"compiled": 0, "loaded": 0, "structures": len(_MODULES)}
    for mod in _MODULES.values():
        for name in ("coefficients", "horner", "fixed", "adaptive", "adaptive_batch"):
            disp = getattr(mod, name, None)
            if disp is None:
                continue
            out["compiled"] += sum(disp._cache_misses.values())
            out["loaded"] += sum(disp._cache_hits.values())
    return out


# ---------------------------------------------------------------- plain-Python path (no numba)
def _py_coefficients(cf: CompiledField, Y, P):
    """The recurrence of the module docstring over the sparse arrays (reference path without numba)."""
    for k in range(P):
        pr = []
        for (i, j), c in zip(cf.mons.tolist(), cf.mcls.tolist()):
            if c in (0, 1):
                pr.append(float(np.dot(Y[i, : k + 1], Y[j, k::-1])))
            elif c == 2:
                pr.append(Y[i, 0] * Y[j, k])
            elif c == 3:
                pr.append(Y[i, k] * Y[j, 0])
            else:
                pr.append(Y[i, 0] * Y[j, 0] if k == 0 else 0.0)
        for c in range(cf.d):
            if cf.const[c]:
                Y[c, k + 1] = 0.0
                continue
            acc = sum(cf.qcoef[t] * pr[cf.qmon[t]] for t in range(cf.qptr[c], cf.qptr[c + 1]))
            acc += sum(cf.lcoef[t] * Y[cf.lidx[t], k] for t in range(cf.lptr[c], cf.lptr[c + 1]))
            Y[c, k + 1] = acc / (k + 1)


def _py_horner(Y, P, h):
    s = Y[:, P].copy()
    for k in range(P - 1, -1, -1):
        s = s * h + Y[:, k]
    Y[:, 0] = s


def _py_fixed(cf, y0, h, nsteps, P, out):
    for n in range(y0.shape[0]):
        Y = np.zeros((cf.d, P + 1))
        Y[:, 0] = y0[n]
        for _ in range(nsteps):
            _py_coefficients(cf, Y, P)
            _py_horner(Y, P, h)
        out[n] = Y[:, 0]


def _py_adaptive(cf, y0, T, tol, P, max_steps, out, steps):
    damp = math.exp(-0.7 / (P - 1))
    sgn, Tabs = (1.0 if T >= 0 else -1.0), abs(T)
    for n in range(y0.shape[0]):
        Y = np.zeros((cf.d, P + 1))
        Y[:, 0] = y0[n]
        t, k, ok = 0.0, 0, True
        while t < Tabs:
            _py_coefficients(cf, Y, P)
            s = tol * max(1.0, float(np.max(np.abs(Y[:, 0]))))
            a1, a2 = float(np.max(np.abs(Y[:, P - 1]))), float(np.max(np.abs(Y[:, P])))
            h = min(
                (s / a1) ** (1 / (P - 1)) if a1 > 0 else np.inf,
                (s / a2) ** (1 / P) if a2 > 0 else np.inf,
            )
            h *= damp
            if not h > 0:
                ok = False
                break
            h, t = (Tabs - t, Tabs) if t + h >= Tabs else (h, t + h)
            _py_horner(Y, P, sgn * h)
            k += 1
            if not np.all(np.isfinite(Y[:, 0])) or k > max_steps:
                ok = False
                break
        out[n] = Y[:, 0] if ok else np.nan
        steps[n] = k if ok else -1
