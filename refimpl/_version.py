"""The package's version, read from the installed distribution's metadata: the one place it is
written is ``pyproject.toml`` (``[project] version``). ``"unknown"`` when tstarg runs from a
folder that was never installed (no metadata)."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("tstarg")
except PackageNotFoundError:  # pragma: no cover - a source tree on sys.path, not installed
    __version__ = "unknown"
