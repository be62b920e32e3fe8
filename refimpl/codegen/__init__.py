"""Code generation: every generated kernel of tstarg, its templates, and the one loader.

Emitters take a field's *structure* (and, for the scalar Python kernels, its numbers as literals) and
return source text; :mod:`refimpl.codegen._loader` is the only place that compiles or imports it.
Golden tests (``tests/test_codegen_golden.py``) pin the generated source per structure key.

* :mod:`refimpl.codegen.scalar` -- straight-line Python and numpy for the polynomial body systems
  (scalar RK, right-hand sides, Taylor steps);
"""

from __future__ import annotations

from ._loader import cache_dir, define, import_source, loaded_modules, template
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
