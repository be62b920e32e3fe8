"""Code generation: every generated kernel of tstarg, its templates, and the one loader.

Emitters take a field's *structure* (and, for the scalar Python kernels, its numbers as literals) and
return source text; :mod:`refimpl.codegen._loader` is the only place that compiles or imports it.
Golden tests (``tests/test_codegen_golden.py``) pin the generated source per structure key.

* :mod:`refimpl.codegen.scalar` -- straight-line Python and numpy for the polynomial body systems
  (scalar RK, right-hand sides, Taylor steps), compiled in memory (numbers as literals);
* :mod:`refimpl.codegen.taylor` -- the compiled (numba) Taylor kernels of the quadratic fields;
* :mod:`refimpl.codegen.rational` -- the compiled Taylor kernels of the rational fields;
* :mod:`refimpl.codegen.tensors` -- the compiled Poisson-tensor kernels;
* ``templates/`` -- the fixed parts as real Python modules (placeholders ``__NAME__``), read as text.

The numba kernels are imported from files named by the hash of their text (:func:`import_source`), so a
kernel's cache key is its source: the golden tests fix both.
"""

from __future__ import annotations

from ._loader import cache_dir, define, fill, import_source, loaded_modules, template
from .scalar import (
    numpy_body_rhs,
    numpy_body_rhs_inplace,
    numpy_taylor_step,
    scalar_rhs,
    scalar_rk,
    scalar_taylor,
)

__all__ = [
    "cache_dir",
    "define",
    "fill",
    "import_source",
    "loaded_modules",
    "numpy_body_rhs",
    "numpy_body_rhs_inplace",
    "numpy_taylor_step",
    "scalar_rhs",
    "scalar_rk",
    "scalar_taylor",
    "template",
]
