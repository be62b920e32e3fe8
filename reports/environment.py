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
    """The commit of the project's git checkout tstarg is imported from (``<sha>+dirty`` with
    local changes to tracked files); None when tstarg's files are not that checkout (an installed
    wheel, also one inside some other repository). The one source of the commit (``tstarg
    --version``, reports, certificates)."""
    root = Path(__file__).resolve().parents[1]
    if not (root / "pyproject.toml").is_file():
        return None

    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            ["git", "-C", str(root), *args], capture_output=True, text=True, timeout=10
        )

    try:
        top = git("rev-parse", "--show-toplevel")
        if top.returncode != 0 or Path(top.stdout.strip()).resolve() != root:
            return None
        sha = git("rev-parse", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    if sha.returncode != 0 or not sha.stdout.strip():
        return None
    return f"{sha.stdout.strip()}+dirty" if dirty.stdout.strip() else sha.stdout.strip()


def _blas() -> list[dict]:
    try:
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
