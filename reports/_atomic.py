"""Writing reports so that none is lost or torn, and runs that do not overwrite each other.

* :func:`write_text` / :func:`write_bytes`: the data goes to a temporary file in the same
  folder (with the permissions the user's umask gives a new file), is flushed and
  ``fsync``-ed, then ``os.replace``-d over the target (atomic on POSIX):
  a reader, or a process killed at any instant, sees the old file or the new one, never a
  truncated one. :func:`save_figure` does the same for matplotlib figures.
* :func:`claim_output`: an exclusive lock (``fcntl.flock`` on ``<folder>/.tstarg.lock``) held
  for the life of the process; a second concurrent run asking for the same folder gets a
  distinct folder inside it (``<folder>/run-<pid>``) instead, and says so on stdout.
* :func:`safe_name`: a file-name component from untrusted text (scene names): no path
  separators, no leading dots, no ``..``, bounded length.
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
from pathlib import Path

__all__ = [
    "LOCK_NAME",
    "claim_output",
    "replacing",
    "safe_name",
    "save_figure",
    "write_bytes",
    "write_text",
]

LOCK_NAME = ".tstarg.lock"
_HELD: dict[str, int] = {}  # folder -> fd of the lock this process holds


def _umask() -> int:
    """The process's umask, read without changing it (Linux ``/proc``), else set and restored."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


def write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (temporary file in the same folder, fsync, replace)."""
    path = Path(path)
    with replacing(path) as tmp:
        tmp.write_bytes(data)
    return path


def _fsync_folder(folder: Path) -> None:
    with contextlib.suppress(OSError):  # make the rename itself durable
        dfd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)


@contextlib.contextmanager
def replacing(path):
    """``with replacing(path) as tmp:`` write ``tmp`` with any writer (a library that wants a
    path); on success it replaces ``path`` atomically (same folder, the permissions the user's
    umask gives a new file -- not mkstemp's 0600 --, the data and then the rename fsync-ed)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_folder(path.parent)


def write_text(path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`write_bytes`)."""
    return write_bytes(path, text.encode(encoding))


def save_figure(fig, path, **kwargs) -> Path:
    """``fig.savefig`` into a temporary file, then atomically onto ``path`` (format from its suffix)."""
    import io

    path = Path(path)
    buf = io.BytesIO()
    kwargs.setdefault("format", path.suffix.lstrip(".") or "png")
    fig.savefig(buf, **kwargs)
    return write_bytes(path, buf.getvalue())


def _try_lock(folder: Path) -> int | None:
    import fcntl

    folder.mkdir(parents=True, exist_ok=True)
    fd = os.open(folder / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    os.ftruncate(fd, 0)
    os.write(fd, f"{os.getpid()}\n".encode())
    return fd


def claim_output(folder, *, announce: bool = True) -> Path:
    """The folder this run writes into: ``folder`` itself if no other live run holds it, else a
    distinct folder ``<folder>/run-<pid>`` (or ``run-<pid>-<k>``) *inside* it, so that a command
    still writes only under the output folder it was given. The lock is held until the process
    exits (the operating system releases it even after ``kill -9``)."""
    folder = Path(folder)
    key = str(folder.resolve())
    if key in _HELD:
        return folder
    candidates = [folder] + [
        folder / (f"run-{os.getpid()}" + (f"-{k}" if k else "")) for k in range(100)
    ]
    for cand in candidates:
        fd = _try_lock(cand)
        if fd is not None:
            _HELD[str(cand.resolve())] = fd
            if cand != folder and announce:
                print(
                    f"{folder} is in use by another running tstarg command: this run writes to {cand}",
                    flush=True,
                )
            return cand
    raise RuntimeError(f"could not lock {folder} or any of 100 alternatives inside it")


_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]+")


def safe_name(name: str, *, default: str = "unnamed", max_len: int = 80) -> str:
    """A single, harmless path component from ``name``: characters outside ``[A-Za-z0-9._+-]``
    become ``_``, leading dots and dashes are stripped (no hidden files, no ``..``, no options),
    and the result is cut to ``max_len``; an empty result becomes ``default``."""
    s = _UNSAFE.sub("_", str(name)).strip()
    s = s.lstrip(".-")
    s = s.replace("..", "_")
    s = s[:max_len].rstrip(".")
    return s or default
