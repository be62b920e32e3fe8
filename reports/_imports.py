"""Resolving ``module:object`` specs given on the command line or in the Python API."""

from __future__ import annotations

import importlib
from types import ModuleType

#: The repository's top-level folders, installed as ``tstarg.<name>``.
HOUSE = ("refimpl", "properties", "oracles", "reports")


def import_module(name: str) -> ModuleType:
    """Import ``name``; a house module may be named without its ``tstarg.`` prefix.

    ``refimpl.fast`` and ``tstarg.refimpl.fast`` name the same module, so the names that
    docs/design.md uses (``tstarg certify refimpl.fast:implementation``) keep working.
    """
    if name.split(".", 1)[0] in HOUSE:
        name = "tstarg." + name
    return importlib.import_module(name)


def resolve(spec: str, *, what: str = "target"):
    """``"package.module:object"`` (object may be dotted) -> the object."""
    if not isinstance(spec, str) or spec.count(":") != 1:
        raise ValueError(f"{what} must look like 'module:object', got {spec!r}")
    mod_name, obj_name = spec.split(":")
    obj = import_module(mod_name)
    for part in obj_name.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise ValueError(f"{what} {spec!r}: {mod_name} has no attribute {obj_name!r}") from None
    return obj
