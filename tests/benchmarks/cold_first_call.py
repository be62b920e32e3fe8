"""The protocol flow's first call from an empty kernel cache, per structure, each in a fresh process.

    python tests/benchmarks/cold_first_call.py --write reports/bench/cold_first_call.md   # all, one table
    python tests/benchmarks/cold_first_call.py --only heavy_top_full,so5 --batch 64 --mode cold

What a new user waits for once per structure (issue 25's target: at most 10 s): a child process
imports tstarg, builds the problem (untimed), then times one ``refimpl.fast.implementation.flow``
call at its default accuracy -- generating, compiling and running that structure's kernels -- in CPU
time (``time.process_time``) and wall time; then, in the same process, a first call of each batch
size of ``--batch`` (perturbed starts; default 64 and ``auto``, the smallest power of two (at least
8) over the batch's work threshold :data:`refimpl._full_state_batch.GENERATED_MIN_WORK` over ``T =
10``: from it the structure's generated lane kernel runs, below it the lane kernel shared by every
structure; with the threshold 0 every batch runs the generated one; the run included). Each child gets a fresh empty ``TSTARG_CACHE_DIR`` (the generated
kernels). Two modes (``--mode``, default both), two children per structure:

* fully cold: a fresh empty ``NUMBA_CACHE_DIR`` too, so the figure includes the package's own
  compiled functions, built once per installation and argument types -- a user's very first call;
* numba-warm: the next child shares the ``NUMBA_CACHE_DIR`` the cold one filled, so the package's
  functions at this structure's types are cached and the figure is the structure's generated
  kernels alone (numba keys a generated module's machine code on its file's path, which differs
  between the two children). With ``--mode warm`` an untimed child fills it first.

Each child also records the compilations numba starts from Python (its outermost ``numba:compile``
events: the functions the call reached, each inclusive of the callees compiled for it), listed per
structure under the table: where the first call's time goes, function by function.

The load average is printed with each figure: CPU time on a loaded machine is inflated too (shared
caches and cores), so compare figures from one run. ``--write PATH`` also writes the table as
markdown (command, commit, machine, load at the start and the end).

Structures: the committed report's protocol problems (``reports._bench_protocol``: su(2) heavy top,
free su(3), se(3), so(4), Bianchi VI0 with a cocycle, su(3) with Theta and Upsilon != 0), the Lagrange
top on su(2), and free tops on so(5), sp(4, R) and sl(3, R) (dimension 10, 10, 8; not in the bench;
so(5) and sp(4, R) built here from matrix bases).
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

from tstarg.reports.environment import git_commit

BENCH_PROBLEMS = (
    "heavy_top_full",
    "free_su3",
    "kirchhoff_se3",
    "manakov_so4",
    "bianchi_cocycle",
    "modified_su3",
)
EXTRA = ("lagrange_top", "so5", "sp4", "sl3")

CHILD = r"""
import json, os, sys, time
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
from numba.core import event as _ev

_open, compiles, phase = [], [], ["single"]


class _Compiles(_ev.Listener):
    # numba's compile events nest (a callee compiles inside its caller's type inference); the outer
    # ones are the functions called from Python, their CPU time inclusive of every callee compiled
    def on_start(self, event):
        _open.append(time.process_time())

    def on_end(self, event):
        t0 = _open.pop()
        if not _open:
            fn = getattr(event.data.get("dispatcher"), "py_func", None)
            name = f"{fn.__module__.rsplit('.', 1)[-1]}.{fn.__qualname__}" if fn else "?"
            compiles.append((phase[0], name, time.process_time() - t0))


_ev.register("numba:compile", _Compiles())
import numpy as np
import sympy
from tstarg.refimpl import LieAlgebra, catalogue
from tstarg.refimpl.fast import implementation as FAST
from tstarg.reports import _bench_protocol as bp
from tstarg.refimpl._full_state_batch import GENERATED_MIN_WORK

name, Ms = sys.argv[1], sys.argv[2].split(",")


def free_top(alg, seed, scale=1.0, T=10.0):
    f = np.array(alg.f, dtype=float)
    n = f.shape[0]
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    inertia = Q @ np.diag(rng.uniform(1.0, 3.0, n)) @ Q.T
    z = np.zeros((n, n))
    x0, pi0 = 0.3 * rng.standard_normal(n), scale * rng.standard_normal(n)
    return (f, z, z, inertia, None, x0, pi0, T)


def so5():
    mats = []
    for i in range(5):
        for j in range(i + 1, 5):
            m = sympy.zeros(5, 5)
            m[i, j], m[j, i] = 1, -1
            mats.append(m)
    return LieAlgebra.from_matrix_basis(mats, name="so(5)")


def sp4():  # [[A, B], [C, -A^T]], B and C symmetric: X^T J + J X = 0
    mats = []
    for i in range(2):
        for j in range(2):
            m = sympy.zeros(4, 4)
            m[i, j], m[2 + j, 2 + i] = 1, -1
            mats.append(m)
    for off in (0, 2):
        for i, j in ((0, 0), (1, 1), (0, 1)):
            m = sympy.zeros(4, 4)
            r, c = (i, 2 + j) if off == 0 else (2 + i, j)
            m[r, c] = 1
            if i != j:
                r2, c2 = (j, 2 + i) if off == 0 else (2 + j, i)
                m[r2, c2] = 1
            mats.append(m)
    return LieAlgebra.from_matrix_basis(mats, name="sp(4,R)")


if name in bp.PROTOCOL_PROBLEMS:
    args = bp.protocol_problem(name).args()
elif name == "lagrange_top":
    z3 = np.zeros((3, 3))
    pot = {"kind": "gravity", "L": np.array([0.0, 0.0, 1.0]), "gamma": np.array([0.0, 0.0, -1.0])}
    args = (np.array(catalogue("su(2)").f, dtype=float), z3, z3, np.diag([1.0, 1.0, 0.5]), pot,
            np.array([0.1, 0.2, 0.0]), np.array([0.3, 0.2, 2.0]), 100.0)
elif name == "so5":
    args = free_top(so5(), 5)
elif name == "sp4":
    args = free_top(sp4(), 4, 0.3, 2.0)  # non-compact: Ad(g) grows, so a short, slow run
elif name == "sl3":
    args = free_top(catalogue("sl(3,R)"), 3, 0.3, 2.0)
else:
    raise SystemExit(f"unknown structure {name!r}")
out = {"n": int(args[0].shape[0])}
w0, c0 = time.perf_counter(), time.process_time()
try:
    FAST.flow(*args)
except ValueError as exc:  # a refusal still compiled (and ran) the kernels: timed, and said
    out["refused"] = str(exc)[:200]
out["single_cpu"], out["single_wall"] = time.process_time() - c0, time.perf_counter() - w0
out["sizes"] = []
for M in Ms if "refused" not in out else []:  # batches in this order, each timed alone
    if M == "auto":  # the smallest power of two (at least 8) over the batch's work threshold
        M = 8
        while M * abs(args[7]) < GENERATED_MIN_WORK:
            M *= 2
    M = int(M)
    if M <= 0:
        continue
    out["sizes"].append(M)
    phase[0] = f"batch {M}"
    rng = np.random.default_rng(3)
    n = out["n"]
    X0 = np.asarray(args[5])[:, None] + 0.01 * rng.standard_normal((n, M))
    P0 = np.asarray(args[6])[:, None] + 0.01 * rng.standard_normal((n, M))
    bargs = args[:5] + (X0.T.copy(), P0.T.copy(), args[7])
    w0, c0 = time.perf_counter(), time.process_time()
    try:
        FAST.flow(*bargs)
    except ValueError as exc:  # a refused row: the kernels were compiled and ran all the same
        out[f"batch{M}_refused"] = str(exc)[:200]
    out[f"batch{M}_cpu"], out[f"batch{M}_wall"] = time.process_time() - c0, time.perf_counter() - w0
out["compiles"] = compiles
print("RESULT " + json.dumps(out))
"""


def run_child(name: str, batches: str, numba_dir: str) -> dict:
    """One fresh process: an empty ``TSTARG_CACHE_DIR`` of its own, ``NUMBA_CACHE_DIR`` as given."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    with tempfile.TemporaryDirectory(prefix="tstarg_cold_") as tmp:
        env["TSTARG_CACHE_DIR"] = os.path.join(tmp, "tstarg")
        env["NUMBA_CACHE_DIR"] = numba_dir
        res = subprocess.run(
            [sys.executable, "-c", CHILD, name, batches],
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
    for line in res.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT ") :])
    raise RuntimeError(f"{name}: the child failed:\n{res.stderr[-3000:]}")


def _say(label: str, name: str, r: dict, t0: float) -> None:
    parts = [f"first call {r['single_cpu']:.2f} s CPU ({r['single_wall']:.2f} s wall)"]
    for M in r["sizes"]:
        parts.append(f"batch of {M}: {r[f'batch{M}_cpu']:.2f} s CPU")
        if f"batch{M}_refused" in r:
            parts.append(f"(batch of {M} refused: {r[f'batch{M}_refused']})")
    if "refused" in r:
        parts.append(f"(the flow refused: {r['refused']})")
    print(
        f"{label} {name} (n = {r['n']}): {', '.join(parts)} "
        f"(child {time.perf_counter() - t0:.1f} s, load {r['load']:.2f})",
        flush=True,
    )


def _measure(name: str, batches: str, modes: list[str], label: str) -> dict:
    """One structure: the fully cold child (a fresh empty ``NUMBA_CACHE_DIR``), then the numba-warm
    child sharing the ``NUMBA_CACHE_DIR`` the cold one filled -- the package's own functions at this
    structure's argument types are cached, its generated kernels are not (each child's own
    ``TSTARG_CACHE_DIR``; numba keys a generated module's machine code on its file's path). Only
    ``warm``: an untimed child fills it first."""
    res = {}
    with tempfile.TemporaryDirectory(prefix="tstarg_numba_") as numba_dir:
        if "cold" not in modes:
            print(f"{label} {name}: warm-up child (untimed) ...", flush=True)
            run_child(name, batches, numba_dir)
        for m in modes:
            print(f"{label} {name}: {m}, fresh process ...", flush=True)
            t0 = time.perf_counter()
            r = run_child(name, batches, numba_dir)
            r["load"] = os.getloadavg()[0]
            _say(f"{label} {m}", name, r, t0)
            res[m] = r
    return res


def _table(rows, modes: list[str]) -> list[str]:
    sizes = []
    for _, res in rows:
        for r in res.values():
            sizes += [M for M in r["sizes"] if M not in sizes]
    cols = []
    for m in modes:
        what = "fully cold" if m == "cold" else "numba-warm"
        cols += [f"first call, {what}", f"batch first calls, {what}"]
    out = [
        "| structure | n | " + " | ".join(cols) + " | load |",
        "|---|---|" + "---|" * len(cols) + "---|",
    ]
    for name, res in rows:
        cells = []
        for m in modes:
            r = res[m]
            cells.append(f"{r['single_cpu']:.2f}" + (" (refused)" if "refused" in r else ""))
            bs = [
                f"{M}: {r[f'batch{M}_cpu']:.2f}"
                + (" (refused)" if f"batch{M}_refused" in r else "")
                for M in r["sizes"]
            ]
            cells.append(", ".join(bs) or "-")
        n = next(iter(res.values()))["n"]
        loads = "/".join(f"{res[m]['load']:.1f}" for m in modes)
        out.append(f"| {name} | {n} | " + " | ".join(cells) + f" | {loads} |")
    return out


def _compile_lines(rows, modes: list[str]) -> list[str]:
    """Per structure and mode: the compilations started from Python (numba's outermost compile events:
    each a function the call reached, its CPU time including every callee compiled for it), largest
    first, per phase (the single call, each batch size)."""
    out = []
    for name, res in rows:
        for m in modes:
            by_phase: dict[str, list] = {}
            for ph, fn, t in res[m].get("compiles", []):
                by_phase.setdefault(ph, []).append((t, fn))
            parts = []
            for ph, items in by_phase.items():
                items.sort(reverse=True)
                shown = ", ".join(f"{fn} {t:.2f}" for t, fn in items if t >= 0.1)
                parts.append(f"{ph}: {shown or '-'} (sum {sum(t for t, _ in items):.2f})")
            what = "fully cold" if m == "cold" else "numba-warm"
            out.append(f"- {name}, {what}: " + ("; ".join(parts) or "nothing compiled"))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="comma-separated structures (default: all)")
    ap.add_argument(
        "--batch",
        default="64,auto",
        help="first batch calls after the single one, in this order (comma-separated sizes; 0: "
        "none; auto: the smallest power of two over the batch's work threshold, so the structure's "
        "generated lane kernel runs; below the threshold the lane kernel shared by every structure "
        "runs)",
    )
    ap.add_argument(
        "--mode",
        choices=("cold", "warm", "both"),
        default="both",
        help="cold: numba cache empty too; warm: the package's own numba functions cached (the "
        "structure's generated kernels alone); both (default)",
    )
    ap.add_argument("--numba-warm", action="store_true", help="the same as --mode warm")
    ap.add_argument("--write", metavar="PATH", help="also write the table as markdown to PATH")
    args = ap.parse_args(argv)
    mode = "warm" if args.numba_warm else args.mode
    modes = ["cold", "warm"] if mode == "both" else [mode]
    names = args.only.split(",") if args.only else list(BENCH_PROBLEMS + EXTRA)
    load0, t_start = os.getloadavg(), time.time()
    rows = []
    for k, name in enumerate(names, 1):
        rows.append((name, _measure(name, args.batch, modes, f"[{k}/{len(names)}]")))
    load1 = os.getloadavg()
    notes = [
        "CPU seconds (`time.process_time` of a fresh child process), one run each; load: the 1-min",
        "load average after each child (cold/warm). Fully cold: `TSTARG_CACHE_DIR` and `NUMBA_CACHE_DIR`",
        "empty (a user's very first call: the package's own compiled functions, built once per",
        "installation and argument types, included). Numba-warm: the package's functions cached, the",
        "structure's generated kernels not (its cost per structure). Batch first calls: in the same",
        "process after the single call, perturbed starts; from `N |T| = GENERATED_MIN_WORK` on (of",
        "refimpl._full_state_batch) the structure's generated lane kernel runs, below it the one",
        "shared by every structure (the run included).",
    ]
    table = _table(rows, modes)
    table += [
        "",
        "Compilations per function (CPU seconds, each including the callees compiled for it; numba's",
        "outermost compile events in the child; generated modules by their file's name):",
        "",
        *_compile_lines(rows, modes),
    ]
    print("\n" + "\n".join(notes + [""] + table))
    if args.write:
        cmd = " ".join(["python tests/benchmarks/cold_first_call.py", *(argv or sys.argv[1:])])
        head = [
            "# The protocol flow's first call per structure (issue 25: at most 10 s)",
            "",
            f"- command: `{cmd}`",
            f"- commit {git_commit() or 'unknown (not a git checkout)'}; {platform.platform()}, {os.cpu_count()} cores, Python "
            f"{platform.python_version()}, numba {importlib.metadata.version('numba')}; load average "
            f"{load0[0]:.2f} at the start, {load1[0]:.2f} at the end (CPU time is inflated on a "
            f"loaded machine too); wall time {time.time() - t_start:.0f} s",
            "",
        ]
        with open(args.write, "w") as fh:
            fh.write("\n".join(head + notes + [""] + table) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
