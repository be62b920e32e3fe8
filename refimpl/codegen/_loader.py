"""The one loader of generated code: templates read as text, sources compiled in memory or imported
from the kernel cache directory.

Three entry points, and the only ``exec`` of the package:

* :func:`template` -- the text of a template module under ``codegen/templates/`` with its lint
  preamble (everything up to the line :data:`BODY_MARK`) dropped;
* :func:`define` -- compile a generated Python source in memory and return one name it defines
  (the scalar and numpy kernels whose numbers are literals: one function per model);
* :func:`import_source` -- write a generated source once into :func:`cache_dir` under the hash of its
  text and import it (the numba kernels, compiled with ``cache=True``: numba keys its machine-code
  cache on the file, so the next process loads machine code; an existing file is never rewritten).

Every cache here is bounded (:data:`MAX_MODULES` imported modules kept, least recently used dropped;
Python's ``sys.modules`` keeps its own reference, so a dropped module is re-fetched from there).
"""

from __future__ import annotations

import hashlib
import importlib
import os
import re
import sys
from collections import OrderedDict
from functools import lru_cache
from pathlib import Path
from types import ModuleType

__all__ = [
    "BODY_MARK",
    "cache_dir",
    "define",
    "fill",
    "import_source",
    "loaded_modules",
    "template",
]

BODY_MARK = "# ---- template body ----"
"""The line after which a template file's text is the template (above it: imports and placeholder
definitions for the linters only)."""

TEMPLATES = Path(__file__).resolve().parent / "templates"
MAX_MODULES = 512  # kernel modules kept by import_source (one per structure and kind)

_LOADED: OrderedDict[str, ModuleType] = OrderedDict()


@lru_cache(maxsize=32)
def template(name: str) -> str:
    """The template ``codegen/templates/<name>.py`` as text, without its lint preamble."""
    text = (TEMPLATES / f"{name}.py").read_text()
    head, sep, body = text.partition(BODY_MARK + "\n")
    if not sep:
        raise ValueError(f"template {name!r} has no line {BODY_MARK!r}")
    return body


def define(src: str, name: str, filename: str, namespace: dict | None = None):
    """Compile ``src`` (a generated Python module text) in ``namespace`` and return its ``name``.

    ``filename`` labels tracebacks (``<tstarg ...>``). The sources are generated from numbers and
    structure only (never from user text)."""
    ns: dict = {} if namespace is None else namespace
    exec(compile(src, filename, "exec"), ns)  # noqa: S102 - generated from numbers and structure only
    return ns[name]


def cache_dir() -> Path:
    """Where the generated kernel modules live: ``$TSTARG_CACHE_DIR`` or ``~/.cache/tstarg``."""
    root = os.environ.get("TSTARG_CACHE_DIR") or os.path.join(
        os.path.expanduser("~"), ".cache", "tstarg"
    )
    return Path(root) / "taylor_kernels"


def import_source(src: str, prefix: str) -> ModuleType:
    """The module ``{prefix}{sha1(src)[:20]}`` written once into :func:`cache_dir` and imported."""
    modname = f"{prefix}{hashlib.sha1(src.encode()).hexdigest()[:20]}"
    mod = _LOADED.get(modname)
    if mod is not None:
        _LOADED.move_to_end(modname)
        return mod
    folder = cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{modname}.py"
    if (
        not path.exists() or path.read_text() != src
    ):  # never rewrite an existing file: numba keys on mtime
        tmp = folder / f".{modname}.{os.getpid()}.tmp"
        tmp.write_text(src)
        os.replace(tmp, path)
    # an importable module (numba's disk cache re-imports the module by name when loading machine code)
    if str(folder) not in sys.path:
        sys.path.append(str(folder))
    mod = importlib.import_module(modname)
    _LOADED[modname] = mod
    if len(_LOADED) > MAX_MODULES:
        _LOADED.popitem(last=False)
    return mod


def loaded_modules(prefix: str) -> list[ModuleType]:
    """The kernel modules of :func:`import_source` currently kept whose name starts with ``prefix``."""
    return [m for k, m in _LOADED.items() if k.startswith(prefix)]


def fill(text: str, **values: str) -> str:
    """``text`` with each placeholder ``__NAME__`` replaced by ``values[NAME]``: a placeholder alone on
    its line (after indentation) replaces the whole line, so a generated block carries its own
    indentation; elsewhere the token itself is replaced. Every placeholder must be given."""
    for name, value in values.items():
        token = f"__{name}__"
        if token not in text:
            raise ValueError(f"template has no placeholder {token}")
        text = re.sub(rf"(?m)^[ \t]*{token}[ \t]*$", lambda _m, v=value: v, text)
        text = text.replace(token, value)
    left = re.findall(r"__[A-Z][A-Z0-9_]*__", text)
    if left:
        raise ValueError(f"template placeholders not filled: {sorted(set(left))}")
    return text
