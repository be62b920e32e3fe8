"""Compiled (numba) Poisson tensors: the su(2) closed form and the generic path (vier9), per point.

Same mathematics, same per-point diagnostics and the same error model as the numpy kernels of
:mod:`refimpl._fast_kernels` (stated in :mod:`refimpl.fast`): every quantity the numpy path forms for
a batch is formed here for one point at a time, in registers and small scratch matrices, and written
straight into the caller's output layout. The output is any ``(N, 2n, 2n)`` view: points-major
(``P[k, i, j]``, the protocol's layout) or a transposed view of a components-first ``(2n, 2n, N)``
array; the inputs ``x``, ``pi`` are ``(N, n)`` views in the same way. No transposing copy is made.

What is compiled (issue 14: per structure, never per model)
    * ``su2``: one kernel for every su(2) model; ``xi`` (from Theta) and ``tau`` (from Upsilon) are
      arguments, and whether each is present is a run-time flag (a branch per point, no code per
      model).
    * ``generic``: one kernel for every algebra: the dimension ``n`` is read from the arrays, ``f``,
      ``Theta``, ``Upsilon`` and the Bernoulli and phi1 coefficients are arguments, the presence of
      Theta and Upsilon run-time flags. (A literal ``n`` per dimension was measured 13% faster on
      su(3) at 10^5 points, but costs a 6-8 s compilation per dimension on a cold cache: six
      dimensions in the catalogue.)

    The sources are written once into the Taylor kernels' cache directory
    (:func:`refimpl.codegen.cache_dir`, ``$TSTARG_CACHE_DIR``) under the hash of their text
    and compiled with ``cache=True``, so a second process loads machine code instead of compiling.
    :func:`compile_count` says how many kernels this process compiled and how many it loaded.

Differences from the numpy path (all inside the same error model)
    * The frame series sums, per point, the number of Bernoulli terms that point's own ``r`` needs
      (the numpy path uses the largest ``r`` of a bin of points); the tail bound
      ``3.3 r^(2K+2)/(1 - r^2) <= eps/8`` holds for every point either way.
    * ``phi1`` by scaling and squaring scales each point by its own Frobenius norm (numpy: the batch's
      largest), and the inverses (``Psi^-1``, ``phi1^-1``) are an LU factorization with partial
      pivoting and one triangular solve pair per column (numpy: LAPACK ``getrf``/``getri``); an
      exactly zero pivot gives NaN, as numpy's per-point fallback does. (Gauss-Jordan elimination,
      tried first, is not backward stable: on se(3) at |pi| ~ 1e6 it lost four more digits in
      ``S Psi^-1`` and broke the bound; tests/test_compiled_tensors.py keeps that point.)
    * Points on the chart edge: the kernel computes the norm bound ``||ad_x||_2 <= min(||.||_F,
      sqrt(||.||_1 ||.||_inf))`` it needs anyway; only points where that bound reaches the edge are
      handed to :func:`refimpl._validate.outside_chart` (eigenvalues), and those are recomputed at
      ``x = 0`` exactly as the numpy path does, then marked NaN with an infinite bound.

Without numba (``HAVE_NUMBA`` False) nothing here runs and :mod:`refimpl._fast_kernels` keeps the
numpy path; :data:`PATH` and the ``path`` field of every result say which path ran.
"""

from __future__ import annotations

import numpy as np

from ._compiled_taylor import HAVE_NUMBA
from ._lru import LRU
from ._phi import PHI1_TAYLOR
from .codegen import import_source, loaded_modules
from .codegen.tensors import generic_source, su2_source

__all__ = ["HAVE_NUMBA", "PATH", "compile_count", "generic_poisson", "su2_poisson"]

PATH = "numba" if HAVE_NUMBA else "numpy"

# ------------------------------------------------------------------------------- the su(2) kernel
# One point per iteration; the formulas, their order and the bound are those of
# refimpl._fast_kernels._su2_poisson_chunk and _su2_frame_coeffs (see their comments).

# --------------------------------------------------------------------------- the generic kernel
# One point per iteration, n = x.shape[1] at run time; the formulas are those of
# refimpl._fast_kernels._generic_poisson_chunk, _frames_generic, _summand_norms (see there).

_BY_CONSTS = LRU(64)  # modules by (kind, dimension, constants): never keyed on a model's numbers


def _su2_module(consts: dict):
    key = ("su2", *consts.items())
    return _BY_CONSTS.get(key, lambda: import_source(su2_source(consts), "tensors_su2_"))


SPECIALISE_FROM = 6
"""Dimensions from which the generic kernel is compiled for its dimension: ``n`` becomes a literal and
the ``n x n`` products keep each row of the result in ``n`` named accumulators (registers, packed
into SIMD lanes by the compiler) instead of in memory, which the compiler must reload and store at
every term because it cannot prove the arrays distinct. One more compilation per dimension, repaid
where the per-point cost is highest (``n >= 6``: se(3), su(3), sl(3,R)); smaller algebras share one
kernel with ``n`` read at run time. Every entry is summed in the same order either way."""


def _generic_module(consts: dict, n: int | None = None):
    dim = int(n) if n is not None and n >= SPECIALISE_FROM else None
    key = ("generic", dim, *consts.items())
    name = "generic" if dim is None else f"generic{dim}"
    return _BY_CONSTS.get(
        key, lambda: import_source(generic_source(consts, dim), f"tensors_{name}_")
    )


def su2_poisson(x, p, xi, tau, out, cond, sens, bound, degen, outside, *, consts: dict) -> None:
    """The su(2) closed form for ``x``, ``p`` (``(N, 3)`` views) into ``out`` (an ``(N, 6, 6)`` view).

    ``xi`` (Theta) and ``tau`` (Upsilon) are 3-vectors or None. ``outside`` receives the chart mask;
    the caller marks those points (they are computed at ``x = 0``). ``consts``: see :mod:`refimpl.codegen.tensors`."""
    mod = _su2_module(consts)
    z = np.zeros(3)
    mod.su2(
        x,
        p,
        z if xi is None else np.asarray(xi, dtype=float),
        xi is not None,
        z if tau is None else np.asarray(tau, dtype=float),
        tau is not None,
        out,
        cond,
        sens,
        bound,
        degen,
        outside,
    )


def generic_poisson(
    f, theta, upsilon, x, p, out, cond, sens, bound, degen, *, bern, consts: dict
) -> np.ndarray:
    """The generic path for ``x``, ``p`` (``(N, n)`` views) into ``out`` (an ``(N, 2n, 2n)`` view).

    ``bern``: ``1, B_2/2!, B_4/4!, ...`` with enough terms for ``r = SERIES_MAX``; ``consts``: see
    :mod:`refimpl.codegen.tensors`. Returns ``r >= ||ad_x||_2 / 2 pi`` per point (the caller's chart pre-filter)."""
    n = f.shape[0]
    mod = _generic_module(consts, n)
    fc = np.ascontiguousarray(f, dtype=float)
    fidx = np.argwhere(fc != 0).astype(np.int64).reshape(-1, 3)
    fval = fc[fc != 0]
    phi1c = PHI1_TAYLOR  # the numba kernel sums phi1 itself (compiled per point); its coefficients are the shared ones
    z = np.zeros((n, n))
    r = np.empty(x.shape[0])
    mod.generic(
        fidx,
        fval,
        z if theta is None else np.ascontiguousarray(theta, dtype=float),
        theta is not None,
        z if upsilon is None else np.ascontiguousarray(upsilon, dtype=float),
        upsilon is not None,
        bern,
        phi1c,
        x,
        p,
        out,
        cond,
        sens,
        bound,
        degen,
        r,
    )
    return r


def compile_count() -> dict:
    """Kernels of this process: ``compiled`` (machine code made here), ``loaded`` (from the disk
    cache), ``structures`` (kernel modules imported). Zeros without numba."""
    mods = loaded_modules("tensors_")
    out = {"compiled": 0, "loaded": 0, "structures": len(mods)}
    for mod in mods:
        for name in ("su2", "generic"):
            disp = getattr(mod, name, None)
            if disp is None:
                continue
            out["compiled"] += sum(disp._cache_misses.values())
            out["loaded"] += sum(disp._cache_hits.values())
    return out
