"""Hostile certification targets and the outcome classifier (issue 30, "Certify under hostile
targets"): one source for the adversarial tests and for the probe script ``probe_certify.py``.

Each case is a Python module or a JSON-lines program written into a scratch folder, certified
with ``python -m tstarg.reports.cli certify ...`` run *from that folder* (the CLI imports from
the current folder, as ``python -m`` does), under a short ``--budget`` (the hard wall) and an
outer timeout that is a multiple of it. Outcomes, as the issue's table counts them:

* ``clear error``: exit 2 with a one-line message on stderr and no traceback;
* ``correct``: the expected verdict: a FAIL certificate (exit 1) for a hostile target, or a PASS
  certificate (exit 0) for a correct target that is merely rude (a non-daemon thread, an atexit);
* ``silent``: exit 0 without a certificate, or a PASS for a target that must fail;
* ``hang``: still running at the outer timeout; ``crash``: a traceback or an unexpected exit code;
* ``lost``: exit 1 without a certificate; ``mutated``: program processes left behind.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

# a correct, cheap target: the fast implementation's Poisson tensor only
CORRECT = """
from tstarg.refimpl.fast import implementation as _fast

class Impl:
    name = "probe"
    def poisson_tensor(self, f, theta, upsilon, x, pi):
        return _fast.poisson_tensor(f, theta, upsilon, x, pi)

implementation = Impl()
"""

MODULES = {
    # name: (module source, expected verdict: "FAIL" | "PASS" | "ERROR")
    "import_os_exit": ("import os\nos._exit(0)\n", "FAIL"),
    "import_sys_exit": ("import sys\nsys.exit(0)\n", "FAIL"),
    "import_keyboard_interrupt": ("raise KeyboardInterrupt\n", "FAIL"),
    "import_sleeps": ("import time\ntime.sleep(10**6)\n", "FAIL"),
    "import_sigkill": ("import os, signal\nos.kill(os.getpid(), signal.SIGKILL)\n", "FAIL"),
    "method_os_exit": (
        CORRECT.replace("return _fast", "import os; os._exit(0); return _fast"),
        "FAIL",
    ),
    "method_sys_exit_0": (
        CORRECT.replace("return _fast", "import sys; sys.exit(0); return _fast"),
        "FAIL",
    ),
    "method_keyboard_interrupt": (
        CORRECT.replace("return _fast", "raise KeyboardInterrupt; return _fast"),
        "FAIL",
    ),
    "method_sigkill": (
        CORRECT.replace("return _fast", "import os; os.kill(os.getpid(), 9); return _fast"),
        "FAIL",
    ),
    "method_blocks_alarm": (
        CORRECT.replace(
            "return _fast",
            "import signal, time; signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM}); "
            "time.sleep(10**6); return _fast",
        ),
        "FAIL",
    ),
    "method_cancels_alarm": (
        CORRECT.replace(
            "return _fast",
            "import signal, time; signal.setitimer(signal.ITIMER_REAL, 0); "
            "signal.signal(signal.SIGALRM, signal.SIG_IGN); time.sleep(10**6); return _fast",
        ),
        "FAIL",
    ),
    "atexit_os_exit": (
        "import atexit, os\natexit.register(lambda: os._exit(0))\n" + CORRECT,
        "PASS",
    ),
    "atexit_raises": ("import atexit\natexit.register(lambda: 1 / 0)\n" + CORRECT, "PASS"),
    "non_daemon_thread": (
        "import threading, time\nthreading.Thread(target=time.sleep, args=(10**6,)).start()\n"
        + CORRECT,
        "PASS",
    ),
    "loose_flow_tolerance": (
        "class Impl:\n    flow_tolerance = 1.0\n"
        "    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):\n"
        "        return x0, pi0\nimplementation = Impl()\n",
        "ERROR",
    ),
    "loose_precision": (CORRECT.replace('name = "probe"', "precision_digits = 1"), "ERROR"),
}

# JSON-lines programs: a correct su(2)-free answer is not needed, each misbehaves at once
_PROGRAM_HEAD = """
import json, os, signal, sys, time
"""
PROGRAMS = {
    "closes_stdout": ("sys.stdout.close(); os.close(1); time.sleep(10**6)\n", "FAIL"),
    "wrong_id": (
        "for line in sys.stdin:\n    r = json.loads(line)\n"
        "    print(json.dumps({'id': r['id'] + 1000, 'error': 'unknown method x'}), flush=True)\n",
        "FAIL",
    ),
    "string_id": (
        "for line in sys.stdin:\n    r = json.loads(line)\n"
        "    print(json.dumps({'id': str(r['id']), 'error': 'unknown method x'}), flush=True)\n",
        "FAIL",
    ),
    "partial_line": (
        'for line in sys.stdin:\n    sys.stdout.write(\'{"id": 1, "res\'); sys.stdout.flush()\n',
        "FAIL",
    ),
    "reads_all_input": ("data = sys.stdin.read()\nprint('{}')\n", "FAIL"),
    "ignores_sigterm": (
        "signal.signal(signal.SIGTERM, signal.SIG_IGN)\nfor line in sys.stdin:\n    pass\n",
        "FAIL",
    ),
    "forks_and_hangs": (
        "import subprocess\n"
        "subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(10**6)'])\n"
        "for line in sys.stdin:\n    pass\n",
        "FAIL",
    ),
}

ARGS = ["--profile", "dev", "--max-examples", "2", "--timeout", "2", "--startup-timeout", "2"]


@dataclass
class Outcome:
    case: str
    category: str
    outcome: str
    code: int | None
    seconds: float
    detail: str


def _leftovers(marker: str) -> list[int]:
    """Live processes whose command line holds ``marker`` (the scratch folder's name)."""
    out = []
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            cmd = Path(entry.path, "cmdline").read_bytes().replace(b"\0", b" ").decode()
            state = Path(entry.path, "stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if marker in cmd and state != "Z":
            out.append(int(entry.name))
    return out


def classify(
    code: int | None, cert: dict | None, stderr: str, expected: str, leftovers: list
) -> str:
    if code is None:
        return "hang"
    if leftovers:
        return "mutated"  # processes left behind: the run did not clean up
    if "Traceback" in stderr:
        return "crash"
    if expected == "ERROR":
        if code == 2 and cert is None and stderr.strip().count("\n") == 0:
            return "clear error"
        return "silent" if code == 0 else "crash"
    if code == 0 and cert is None:
        return "silent"
    if cert is None:
        return "lost" if code == 1 else "crash"
    if expected == "FAIL":
        if cert.get("passed"):
            return "silent"
        return "correct" if code == 1 else "crash"
    return "correct" if (code == 0 and cert.get("passed")) else "crash"


def run_case(
    name: str, folder: Path, *, budget: float = 30.0, kind: str = "module", check: str | None = None
) -> Outcome:
    """Certify one hostile case from ``folder`` and classify the outcome."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / f"out_{name}"
    if kind == "module":
        src, expected = MODULES[name]
        mod = f"hostile_{name}"
        (folder / f"{mod}.py").write_text(textwrap.dedent(src))
        target = [f"{mod}:implementation" if "implementation" in src else mod]
        checks = ["--check", check or "poisson_tensor.antisymmetry", "--workers", "1"]
        if name == "loose_flow_tolerance":
            checks = ["--check", "flow.reference", "--workers", "1"]
    else:
        src, expected = PROGRAMS[name]
        prog = folder / f"hostile_{name}.py"
        prog.write_text(_PROGRAM_HEAD + src)
        target = ["--cmd", f"{sys.executable} {prog}"]
        checks = ["--check", check or "poisson_tensor.antisymmetry", "--workers", "2"]
    argv = [sys.executable, "-m", "tstarg.reports.cli", "certify", *target, *ARGS, *checks]
    argv += ["--budget", str(budget), "--out", str(out)]
    env = dict(os.environ, PYTHONPATH=os.environ.get("PYTHONPATH", ""))
    t0 = time.monotonic()
    try:
        done = subprocess.run(
            argv,
            cwd=folder,
            capture_output=True,
            text=True,
            timeout=3 * budget + 60,
            env=env,
            check=False,
        )
        code, stderr = done.returncode, done.stderr
    except subprocess.TimeoutExpired as exc:
        code, stderr = None, (exc.stderr or b"").decode(errors="replace")
    seconds = time.monotonic() - t0
    time.sleep(0.5)
    left = _leftovers(str(folder / f"hostile_{name}"))
    path = out / "certificate.json"
    cert = json.loads(path.read_text()) if path.is_file() else None
    outcome = classify(code, cert, stderr, expected, left)
    for pid in left:  # clean up after a failed case, by pid (only processes of this case)
        try:
            os.kill(pid, 9)
        except OSError:
            pass
    detail = (stderr.strip().splitlines() or [""])[-1][:200]
    if cert is not None:
        bad = [c for c in cert["checks"] if not c["passed"]]
        detail = (bad[0]["detail"] if bad else "PASS")[:200]
    return Outcome(name, f"certify {kind}", outcome, code, seconds, detail)


# ------------------------------------------------------------------ jobs for run_supervised
def job_returns(job):
    """Returns its job, after starting a non-daemon thread and a hostile atexit."""
    import atexit
    import threading

    threading.Thread(target=time.sleep, args=(10**6,)).start()
    atexit.register(os._exit, 3)
    return {"echo": job}


def job_hangs_with_grandchild(job):
    """Starts a grandchild in a new process group that ignores SIGTERM, records its pid, hangs."""
    import signal

    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    child = subprocess.Popen(
        [sys.executable, "-c", "import signal, time; signal.signal(15, 1); time.sleep(10**6)"],
        process_group=0,
    )
    Path(job).write_text(str(child.pid))
    time.sleep(10**6)


def job_exits(job):
    os._exit(0)
