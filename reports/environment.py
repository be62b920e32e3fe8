"""Where a run ran: the environment block of reports and certificates (one source for both).

:func:`environment` returns the platform, the versions of Python and of the numerical
libraries, the BLAS libraries loaded (from ``threadpoolctl``: name, version, threads), tstarg's
version and the git commit of the source tree tstarg was imported from (``None`` outside a
git checkout).
"""

from __future__ import annotations

import functools
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path

__all__ = ["environment", "git_commit", "tstarg_version"]

_LIBRARIES = ("numpy", "scipy", "numba", "mpmath", "sympy", "hypothesis", "python-flint")


def tstarg_version() -> str:
    try:
        return metadata.version("tstarg")
    except metadata.PackageNotFoundError:  # pragma: no cover - run from a bare checkout
        return "unknown"


@functools.cache
def git_commit() -> str | None:
    """The commit of the checkout tstarg is imported from (with ``+dirty`` for local changes)."""
    root = Path(__file__).resolve().parent.parent
    try:
        sha = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{sha}+dirty" if dirty else sha or None


def _blas() -> list[dict]:
    try:
        # local: imported for their side effect (the BLAS threadpoolctl then reports), and kept
        # out of the light command line (tstarg --version reads git_commit from this module)
        import numpy  # noqa: F401 - loads the BLAS threadpoolctl reports
        import scipy.linalg  # noqa: F401
        from threadpoolctl import threadpool_info

        return [
            {
                "api": i.get("internal_api"),
                "library": Path(i.get("filepath") or "").name,
                "version": i.get("version"),
                "threads": i.get("num_threads"),
            }
            for i in threadpool_info()
        ]
    except Exception:  # noqa: BLE001 - the environment block must never break a report
        return []


def environment() -> dict:
    """The environment block (JSON-ready)."""
    versions = {}
    for lib in _LIBRARIES:
        try:
            versions[lib] = metadata.version(lib)
        except metadata.PackageNotFoundError:
            versions[lib] = None
    return {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "python": sys.version.split()[0],
        "implementation": platform.python_implementation(),
        "libraries": versions,
        "blas": _blas(),
        "tstarg": tstarg_version(),
        "git_commit": git_commit(),
    }
