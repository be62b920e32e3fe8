"""Malformed input files for the commands that read them (issue 30, "Scenes and reports"): one
source for ``test_files.py`` and the probe script.

Each case is a path (made by :func:`make_inputs` in a scratch folder) fed to ``tstarg run``,
``tstarg verify --baseline``, ``tstarg report`` and ``tstarg certify --replay``. The expected
outcome is a clear error: exit 2, one line on stderr, no traceback, nothing written, within a
few seconds (a FIFO or ``/dev/zero`` must not be read forever).
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

DEEP = 100_000


def make_inputs(folder: Path) -> dict[str, str]:
    """name -> path of each malformed input."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    files = {
        "empty": b"",
        "truncated_json": b'{"checks": [{"name": "a", "passed": tr',
        "a_list": b"[1, 2, 3]",
        "wrong_types": b'{"checks": [{"name": 7, "passed": "yes"}]}',
        "nan_digits": b'{"checks": [{"name": "a", "passed": true, "min_digits": NaN, "worst_ratio": 0}]}',
        "deep_json": b"[" * DEEP + b"]" * DEEP,
        "deep_toml": b"a = " + b"[" * DEEP + b"]" * DEEP + b"\n",
        "binary": bytes(range(256)) * 64,
        "truncated_toml": b'name = "x"\nalgebra = "su(2)"\ninertia = [[1, 0',
        "toml_list": b"scene = [1, 2]\n",
    }
    out = {}
    for name, data in files.items():
        p = folder / f"{name}.{'toml' if 'toml' in name else 'json'}"
        p.write_bytes(data)
        out[name] = str(p)
    fifo = folder / "fifo.json"
    if not fifo.exists():
        os.mkfifo(fifo)
    out["fifo"] = str(fifo)
    out["dev_zero"] = "/dev/zero"
    out["dev_urandom"] = "/dev/urandom"
    empty_dir = folder / "empty_folder"
    empty_dir.mkdir(exist_ok=True)
    out["empty_folder"] = str(empty_dir)
    dotdot = folder / "..toml"
    dotdot.write_bytes(b"")
    out["dotdot_toml"] = str(dotdot)
    out["missing"] = str(folder / "no_such_file.json")
    return out


def commands(path: str, folder: Path) -> dict[str, list[str]]:
    """The commands that read ``path`` (each writing, if at all, under ``folder``)."""
    out = str(Path(folder) / "out")
    return {
        "run": ["run", path, "--out", out, "--no-plot"],
        "verify --baseline": [
            "verify",
            "--baseline",
            path,
            "--provider",
            "tstarg.properties.core_checks:nothing_here",
            "--out",
            out,
        ],
        "report": ["report", path, "--out", out],
        "report --compare": ["report", "--compare", path, path, "--out", out],
        "certify --replay": [
            "certify",
            "tstarg.refimpl.fast:implementation",
            "--replay",
            path,
            "--out",
            out,
        ],
    }


def run_file_case(command: list[str], folder: Path, timeout: float = 60.0) -> tuple[str, str]:
    """(outcome, last stderr line) for one ``tstarg`` command on a malformed file."""
    folder = Path(folder)
    t0 = time.monotonic()
    try:
        done = subprocess.run(
            [sys.executable, "-m", "tstarg.reports.cli", *command],
            cwd=folder,
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired:
        return "hang", f"still running after {timeout:g} s"
    err = done.stderr.strip()
    last = (err.splitlines() or [""])[-1][:200]
    if "Traceback" in err:
        return "crash", last
    if done.returncode == 2 and err.count("\n") == 0 and err:
        wrote = (folder / "out").exists() and any((folder / "out").iterdir())
        return ("lost" if wrote else "clear error"), last
    if done.returncode == 0:
        return "silent", (done.stdout.strip().splitlines() or [""])[-1][:200]
    return "crash", f"exit {done.returncode}: {last} ({time.monotonic() - t0:.1f} s)"
