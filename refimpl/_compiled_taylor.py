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
    (:func:`refimpl.flows.fast_flow` compares two tolerances).

Without numba (``HAVE_NUMBA`` False) the same functions run as plain Python (slow but exact same
arithmetic); :data:`PATH` says which path ran.
"""

from __future__ import annotations

import math

import numpy as np

from ._lru import LRU
from .codegen import import_source, loaded_modules
from .codegen.taylor import BATCH_WIDTH, batch_source, loop_source, unrolled_source

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
    "unrolled_adaptive",
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


MAX_UNROLLED_ORDER = (
    30  # beyond this the loop kernels (codegen template taylor_loop) run (order an argument)
)
UNROLL_BUDGET = (
    4500  # unrolled Cauchy-product terms (monomials * P(P+1)/2) above which the loop kernel
)
# runs instead: LLVM's compile time grows with the straight-line code (a heavy top's full state at order 20
# has about 4200 and compiles in ~2 s; larger structures would take tens of seconds once)


BATCH_MIN = 64  # trajectories from which taylor_adaptive runs the batch kernel by default


def _unrolls(cf: CompiledField, order) -> bool:
    return (
        order is not None
        and order <= MAX_UNROLLED_ORDER
        and len(cf.mons) * order * (order + 1) // 2 <= UNROLL_BUDGET
    )


def _import_kernel_module(src: str):
    """The kernel module of ``src`` (:func:`refimpl.codegen.import_source`, prefix ``taylor_``)."""
    return import_source(src, "taylor_")


def structure_kernels(cf: CompiledField, order: int | None = None):
    """The compiled module for the structure of ``cf``: unrolled at ``order`` (``adaptive(y0, T, tol,
    max_steps, q, l, out, nsteps)``, ``fixed(y0, h, nsteps, q, l, out)``) when ``order`` is given and at
    most :data:`MAX_UNROLLED_ORDER`, else the loop kernels (order an argument). None without numba."""
    if not HAVE_NUMBA:
        return None
    skey = (cf.structure_key(), order if _unrolls(cf, order) else None)
    return _BY_STRUCTURE.get(skey, lambda: _structure_module(cf, order))


_BY_STRUCTURE = LRU(256)  # kernel modules by (structure, order): never keyed on a model's numbers


def batch_kernels(cf: CompiledField, order: int):
    """The compiled batch module (:func:`refimpl.codegen.taylor.batch_source`) for the structure of ``cf`` at ``order``
    (unrolled structures only; None without numba)."""
    if not HAVE_NUMBA or not _unrolls(cf, order):
        return None
    skey = (cf.structure_key(), int(order), "batch", BATCH_WIDTH)
    return _BY_STRUCTURE.get(skey, lambda: _import_kernel_module(batch_source(cf, int(order))))


def _structure_module(cf: CompiledField, order):
    if _unrolls(cf, order):
        return _import_kernel_module(unrolled_source(cf, int(order)))
    return _import_kernel_module(loop_source(cf))


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


def _unrolled_module(cf: CompiledField, P: int):
    """The unrolled kernel module of ``cf`` at order ``P`` (kept per field), or None when that order is
    not unrolled (or numba is missing)."""
    kern = cf._kernels.get(P)
    if kern is None:
        kern = cf._kernels[P] = (structure_kernels(cf, P), _unrolls(cf, P))
    mod, unrolled = kern
    return mod if mod is not None and unrolled else None


def unrolled_adaptive(cf: CompiledField, order: int):
    """The unrolled single-trajectory kernel ``adaptive(y0, T, tol, max_steps, q, l, out, nsteps)`` of
    ``cf`` at ``order`` (the one :func:`taylor_adaptive` runs for fewer than :data:`BATCH_MIN` rows),
    or None when that order is not unrolled (or numba is missing): for callers that run it directly,
    without this module's per-call checks (one trajectory, ``y0`` a C-contiguous float64 (1, d))."""
    mod = _unrolled_module(cf, int(order))
    return None if mod is None else mod.adaptive


def unrolled_pair(cf: CompiledField, order: int):
    """The unrolled pair kernel ``pair(y0, T, tol_a, tol_b, max_steps, q, l, out_a, out_b, steps_a,
    steps_b)`` of ``cf`` at ``order`` (:func:`refimpl.codegen.taylor.unrolled_source`: the kernel
    ``adaptive`` at two local tolerances, the two runs on the lanes of one vector while both go on, the
    one left over alone; each run's result and steps those of ``adaptive`` at its tolerance, bit for
    bit), or None as :func:`unrolled_adaptive`; called as it is, without checks."""
    mod = _unrolled_module(cf, int(order))
    return None if mod is None else mod.pair


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

    ``batch``: run the SIMD batch kernel (:func:`refimpl.codegen.taylor.batch_source`: the same recurrence and control per trajectory, its sums in another order; about
    2.5x the throughput) -- by default when ``N >= BATCH_MIN`` (its one-off compilation, about 2 s per
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
    mods = loaded_modules("taylor_")
    out = {"compiled": 0, "loaded": 0, "structures": len(mods)}
    for mod in mods:
        for name in ("coefficients", "horner", "fixed", "adaptive", "adaptive_batch", "pair"):
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
