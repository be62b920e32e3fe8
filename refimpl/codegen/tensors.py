"""Generated compiled Poisson-tensor kernels (:mod:`refimpl._compiled_tensors`).

The error model's constants (``EPS``, ``C_P``, ``TWO_PI``, ``SERIES_MAX``, given by
:mod:`refimpl._fast_kernels`) are written in as literals; the generic kernel is either read at run
time for its dimension or written for one dimension ``n`` (the ``n x n`` products of
:func:`_mm_unrolled`). Templates: ``templates/su2_tensor.py``, ``templates/generic_tensor.py``.
"""

from __future__ import annotations

from ._loader import fill, template

__all__ = ["generic_source", "su2_source"]


def _consts(consts: dict, *names: str) -> dict:
    return {k: repr(float(consts[k])) for k in names}


def su2_source(consts: dict) -> str:
    """The su(2) closed-form kernel with the constants written in."""
    return fill(template("su2_tensor"), **_consts(consts, "EPS", "C_P", "TWO_PI"))


_MM_LOOP = """    # c = a @ b (n x n)
    for i in range(NDIM):
        for j in range(NDIM):
            c[i, j] = 0.0
        for l in range(NDIM):
            ail = a[i, l]
            for j in range(NDIM):
                c[i, j] += ail * b[l, j]"""


def _mm_unrolled(n: int) -> str:
    """The body of ``_mm`` for dimension ``n``: row ``i`` of ``a @ b`` in the accumulators ``c0..c{n-1}``,
    terms added in the order ``l = 0, 1, ...`` (as the loop form)."""
    acc = ", ".join(f"c{j}" for j in range(n))
    lines = [f"    # c = a @ b ({n} x {n}), row by row in registers", f"    for i in range({n}):"]
    lines.append(f"        {acc} = {', '.join('0.0' for _ in range(n))}")
    lines.append(f"        for l in range({n}):")
    lines.append("            ail = a[i, l]")
    lines += [f"            c{j} += ail * b[l, {j}]" for j in range(n)]
    lines += [f"        c[i, {j}] = c{j}" for j in range(n)]
    return "\n".join(lines)


def generic_source(consts: dict, n: int | None) -> str:
    """The generic kernel's source: ``n`` read at run time (None), or written in for dimension ``n``
    with the products of :func:`_mm_unrolled`."""
    src = fill(
        template("generic_tensor"),
        MM_BODY=_MM_LOOP if n is None else _mm_unrolled(int(n)),
        **_consts(consts, "EPS", "C_P", "TWO_PI", "SERIES_MAX"),
    )
    if n is not None:
        for arr in ("a.shape[0]", "W.shape[0]", "x.shape[1]"):
            src = src.replace(f"NDIM = {arr}", f"NDIM = {int(n)}")
    return src
