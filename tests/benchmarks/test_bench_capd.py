"""Benchmark: rigorous flow enclosures, tstarg against CAPD (double intervals), radius against CPU time.

One command prints (and with ``--write`` commits) the whole comparison::

    python tests/benchmarks/test_bench_capd.py --write reports/bench/capd.md

(``python -m pytest -p no:cacheprovider -n 0 -m slow tests/benchmarks/test_bench_capd.py -s`` runs
the same table as a test, asserting the containment below.)

Problems (issue 28): the heavy top (Euler-Poisson, I = diag(1, 1, 0.5), L = e3, pi0 = (0.3, 0.2, 2),
Gamma0 = Ad(exp x0)^T (0, 0, -1), x0 = (0.1, 0.2, 0)), the free se(3) body and a su(2) model with a Theta
coboundary, at T = 1 and T = 10. Both tools integrate the same quadratic body field
(``refimpl._rigorous_flow.body_field`` with the products ``y_j y_k``, ``y_k y_j`` merged,
``refimpl._interval_flow.merged_terms``; CAPD receives it as a formula string, a coefficient that is
not an exact double as a parameter set to the same outward interval as in tstarg's tables) from the
same initial box (the outward doubles of the Arb ball of the state at ``t = 0``; a point where the
state is an exact double).

Contenders, interleaved (each repeat runs every contender once, forward and backward in turn; the best
of ``--repeat`` CPU times, ``time.process_time``, BLAS on one thread; every compilation done before
timing):

* ``tstarg`` -- ``interval_body_enclosure`` (compiled double intervals, 53 bits), a ladder of per-step
  tolerances ``tol`` at the default order ``default_order(tol)``. ``CPU call``: the whole call
  (validation, the Arb set-up of the field and of Gamma0, the kernel); ``CPU field``: from the model's
  ball field, as CAPD starts from its formula (``interval_tables`` + ``interval_enclose``).
* ``CAPD`` -- ``IOdeSolver`` + ``ITimeMap`` on a ``C0HOTripletonSet``, a ladder of (order, tolerance);
  its CPU time is the whole call from the formula (``IMap`` parse, solver, integration).

``ratio`` = tstarg's CPU time over CAPD's at equal radius: on a tstarg row, over the cheapest CAPD run
whose radius is at most this row's; on a CAPD row, the cheapest tstarg run at least as tight over this
row's time (``-`` when there is none). ``< 1``: tstarg reaches that radius in less CPU time. Ratios use
``CPU call`` (``CPU field`` in brackets). Containment: every box contains the midpoint of the Arb
enclosure at 200 bits (radius below 1e-40), which is computed once, untimed.

CAPD is optional: the PyPI package ``uj-capdpy`` (module ``capdpy``), which builds from source (about
7 min and more on a loaded machine; it fetches its own cmake wheel): ``pip install -e ".[capd]"``.
Without it the CAPD rows are skipped and only tstarg's curves are printed.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import os
import platform
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from tstarg.refimpl import _interval_flow as IF  # noqa: E402
from tstarg.refimpl import _interval_kernel as K  # noqa: E402
from tstarg.refimpl import catalogue, su2  # noqa: E402
from tstarg.refimpl._arb import workprec  # noqa: E402
from tstarg.refimpl._interval_flow import (  # noqa: E402
    SETUP_BITS,
    _bounds,
    default_order,
    interval_body_enclosure,
    interval_enclose,
    interval_tables,
    merged_terms,
)
from tstarg.refimpl._rigorous_flow import body_field  # noqa: E402
from tstarg.refimpl.rigorous import body_flow_enclosure  # noqa: E402
from tstarg.reports.environment import git_commit  # noqa: E402

Z3 = np.zeros((3, 3))
GRAV = {"kind": "gravity", "L": np.array([0.0, 0.0, 1.0]), "gamma": np.array([0.0, 0.0, -1.0])}
TIMES = (1.0, 10.0)
TOLS = (1e-6, 1e-8, 1e-10, 1e-12, 1e-14, 1e-16, 1e-18)  # tstarg's per-step tolerances
CAPD_LADDER = (
    (8, 1e-6),
    (10, 1e-8),
    (12, 1e-10),
    (15, 1e-12),
    (18, 1e-14),
    (20, 1e-16),
    (25, 1e-18),
)
REPEAT = 3


def _problems():
    se3 = catalogue("se(3)")
    xi = np.array([0.25, 0.0, 0.125])
    return {
        "heavy top": (
            su2(),
            Z3,
            np.diag([1.0, 1.0, 0.5]),
            GRAV,
            np.array([0.1, 0.2, 0.0]),
            np.array([0.3, 0.2, 2.0]),
        ),
        "free se(3)": (
            se3,
            np.zeros((6, 6)),
            np.diag([1.0, 2.0, 3.0, 1.0, 1.5, 2.0]),
            None,
            np.zeros(6),
            np.array([0.3, 0.2, 0.5, 0.1, 0.2, 0.3]),
        ),
        "su(2), Theta": (
            su2(),
            -np.einsum("k,kab->ab", xi, su2().f),
            np.diag([1.0, 1.3, 0.5]),
            None,
            np.zeros(3),
            np.array([0.3, 0.2, 2.0]),
        ),
    }


def _balls(e) -> list:
    return list(e.pi.balls) + (list(e.Gamma.balls) if e.Gamma is not None else [])


def _setup(prob):
    """``(F, start box lo, hi, CAPD formula)``: the ball field, the outward doubles of the Arb initial
    state, and the field as CAPD's formula string (the merged terms tstarg's kernel runs) with the
    coefficients that are not exact doubles as parameters (the outward intervals of ``_bounds``)."""
    alg, th, inertia, pot, x0, pi0 = prob
    e0 = body_flow_enclosure(
        alg, th, np.zeros_like(th), inertia, pot, x0, pi0, 0.0, prec_bits=SETUP_BITS
    )
    b = [_bounds(v) for v in _balls(e0)]
    with workprec(SETUP_BITS):
        F, _ = body_field(alg, th, inertia, pot)
    const, lin, quad = merged_terms(F)
    names = [f"y{i}" for i in range(F.d)]
    params = []  # (name, lo, hi): a coefficient that is not an exact double, as a CAPD interval

    def coef(ball) -> str:
        lo, hi = _bounds(ball)
        if lo == hi:
            return f"({lo!r})"
        params.append((f"c{len(params)}", lo, hi))
        return params[-1][0]

    rows = []
    for i in range(F.d):
        terms = []
        if i in const:
            terms.append(coef(const[i]))
        for j, a in sorted(lin[i].items()):
            terms.append(f"{coef(a)}*{names[j]}")
        for (j, k), q in sorted(quad[i].items()):
            terms.append(f"{coef(q)}*{names[j]}*{names[k]}")
        rows.append("+".join(terms) if terms else "0")
    par = f"par:{','.join(p for p, _, _ in params)};" if params else ""
    formula = (f"{par}var:{','.join(names)};fun:{','.join(rows)};", params)
    return F, [x for x, _ in b], [y for _, y in b], formula


def _capd_run(capd, formula, lo0, hi0, T, order, tol):
    text, params = formula
    vf = capd.IMap(text)
    for p, lo, hi in params:  # the same outward coefficient intervals as tstarg's tables
        vf.setParameter(p, capd.Interval(lo, hi))
    solver = capd.IOdeSolver(vf, order)
    solver.setAbsoluteTolerance(tol)
    solver.setRelativeTolerance(tol)
    tm = capd.ITimeMap(solver)
    u = capd.IVector(len(lo0))
    for i, (a, b) in enumerate(zip(lo0, hi0)):
        u[i] = capd.Interval(a, b)
    s = capd.C0HOTripletonSet(u)
    r = tm(capd.Interval(T), s)
    lo = np.array([float(r[i].leftBound()) for i in range(len(lo0))])
    hi = np.array([float(r[i].rightBound()) for i in range(len(lo0))])
    if IF._LIBM is not None and IF._FE is not None and K.rounding_mode(K.PROBE) != 0:
        IF._LIBM.fesetround(IF._FE[0])  # CAPD leaves the FPU in directed rounding: give it back
    return lo, hi


def _iv_call(prob, T, tol):
    alg, th, inertia, pot, x0, pi0 = prob
    e = interval_body_enclosure(alg, th, np.zeros_like(th), inertia, pot, x0, pi0, T, tol=tol)
    return e.lo, e.hi


def _iv_field(F, lo0, hi0, T, tol):
    order = default_order(tol)
    lo, hi, _, _ = interval_enclose(
        interval_tables(F), lo0, hi0, T, order=order, jac_order=min(6, order), tol=tol
    )
    return lo, hi


def _reference(prob, T) -> np.ndarray:
    alg, th, inertia, pot, x0, pi0 = prob
    ref = body_flow_enclosure(
        alg, th, np.zeros_like(th), inertia, pot, x0, pi0, T, prec_bits=200, order=40
    )
    return np.array([float(b.mid()) for b in _balls(ref)])


def _capd_module():
    try:
        import capdpy  # the optional peer (PyPI uj-capdpy): a benchmark-only dependency
    except ImportError:
        return None
    return capdpy


def run(names=None, times=TIMES, repeat=REPEAT, out=print) -> list:
    """Run the comparison; returns the rows ``(problem, T, tool, order, tol, radius, cpu_call,
    cpu_field, ratio_call, ratio_field)`` and asserts that every box contains the reference."""
    capd = _capd_module()
    probs = _problems()
    rows = []
    for name in names or list(probs):
        prob = probs[name]
        F, lo0, hi0, formula = _setup(prob)
        for T in times:
            ref = _reference(prob, T)
            cont = []  # (tool, order, tol, [run, run_field])
            for tol in TOLS:
                cont.append(
                    (
                        "tstarg",
                        default_order(tol),
                        tol,
                        [
                            lambda t=tol: _iv_call(prob, T, t),
                            lambda t=tol: _iv_field(F, lo0, hi0, T, t),
                        ],
                    )
                )
            if capd is not None:
                for order, tol in CAPD_LADDER:
                    cont.append(
                        (
                            "CAPD",
                            order,
                            tol,
                            [lambda o=order, t=tol: _capd_run(capd, formula, lo0, hi0, T, o, t)],
                        )
                    )
            for _tool, _o, _t, runs in cont:  # compile / warm every route once, untimed
                for r in runs:
                    r()
            best = [[float("inf")] * len(c[3]) for c in cont]
            boxes: list = [None] * len(cont)
            for rep in range(repeat):  # interleaved: every contender once per repeat
                print(f"\r{name}, T = {T:g}: repeat {rep + 1}/{repeat}", end="", file=sys.stderr)
                order = range(len(cont)) if rep % 2 == 0 else range(len(cont) - 1, -1, -1)
                for i in order:  # forward, then backward: no contender always runs first
                    runs = cont[i][3]
                    for j, r in enumerate(runs):
                        t0 = time.process_time()
                        box = r()
                        best[i][j] = min(best[i][j], time.process_time() - t0)
                        if j == 0:
                            boxes[i] = box
            print(file=sys.stderr)
            prow = []
            for (tool, order, tol, _runs), cpu, (lo, hi) in zip(cont, best, boxes):
                assert np.all(lo <= ref) and np.all(ref <= hi), (name, T, tool, order, tol)
                rad = float(np.max(hi - lo) / 2)
                prow.append([name, T, tool, order, tol, rad, cpu[0], cpu[-1], None, None])
            capd_rows = [r for r in prow if r[2] == "CAPD"]
            ts_rows = [r for r in prow if r[2] == "tstarg"]
            for r in ts_rows:
                peers = [c[6] for c in capd_rows if c[5] <= r[5]]
                if peers:
                    r[8], r[9] = r[6] / min(peers), r[7] / min(peers)
            for c in capd_rows:
                ours = [r for r in ts_rows if r[5] <= c[5]]
                if ours:
                    c[8] = min(r[6] for r in ours) / c[6]
                    c[9] = min(r[7] for r in ours) / c[6]
            rows += prow
            for line in _table(prow, header=not rows[: -len(prow)]):
                out(line)
    if capd is None:
        out("CAPD rows skipped: `import capdpy` failed (pip install -e '.[capd]')")
    return rows


def _table(rows, header=True) -> list:
    lines = []
    if header:
        lines += [
            "| problem | T | tool | order | tol | radius | CPU call ms | CPU field ms | ratio |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
    for name, T, tool, order, tol, rad, c1, c2, r1, r2 in rows:
        ratio = "-" if r1 is None else f"{r1:.2f} ({r2:.2f})"
        field = f"{c2 * 1e3:.2f}" if tool == "tstarg" else ""
        lines.append(
            f"| {name} | {T:g} | {tool} | {order} | {tol:g} | {rad:.2g} | {c1 * 1e3:.2f} | "
            f"{field} | {ratio} |"
        )
    return lines


def _capd_version() -> str:
    try:
        return importlib.metadata.version("uj-capdpy")
    except importlib.metadata.PackageNotFoundError:
        return "?"


def _summary(rows) -> list:
    """Per problem and T: the range of the ratios at equal radius (whole call; from the field)."""
    out = ["## Summary: tstarg's CPU over CAPD's at equal radius (tstarg rows)", ""]
    for name in dict.fromkeys(r[0] for r in rows):
        for T in dict.fromkeys(r[1] for r in rows if r[0] == name):
            ts = [r for r in rows if r[0] == name and r[1] == T and r[2] == "tstarg"]
            rs = [r for r in ts if r[8] is not None]
            if not rs:
                continue
            c = [r[8] for r in rs]
            f = [r[9] for r in rs]
            tight = min(ts, key=lambda r: r[5])
            loose = max(ts, key=lambda r: r[5])
            out.append(
                f"- {name}, T = {T:g}: ratio call {min(c):.2f}-{max(c):.2f}, field {min(f):.2f}-"
                f"{max(f):.2f}; tstarg's call {tight[6] * 1e3:.2f} ms at radius {tight[5]:.2g} "
                f"(tol {tight[4]:g}), {loose[6] * 1e3:.2f} ms at {loose[5]:.2g} (tol {loose[4]:g})"
            )
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--write", metavar="PATH", help="also write the table as markdown to PATH")
    ap.add_argument("--repeat", type=int, default=REPEAT, help="timed repeats (best of)")
    a = ap.parse_args(argv)
    if a.repeat < 1:
        ap.error("--repeat must be >= 1")
    load0 = os.getloadavg()
    t0 = time.time()
    lines: list = []
    rows = run(repeat=a.repeat, out=lambda s: (print(s, flush=True), lines.append(s)))
    load1 = os.getloadavg()
    if a.write:
        capd = _capd_module()
        head = [
            "# Rigorous flow enclosures: tstarg against CAPD, radius against CPU time",
            "",
            f"- command: `python tests/benchmarks/test_bench_capd.py --write {a.write}"
            + (f" --repeat {a.repeat}`" if a.repeat != REPEAT else "`"),
            f"- commit {git_commit() or 'unknown (not a git checkout)'}; {platform.platform()}, {os.cpu_count()} cores, load average "
            f"{load0[0]:.2f} at the start, {load1[0]:.2f} at the end (other processes share the "
            "cores: compare ratios from this run, not times across runs); wall time "
            f"{time.time() - t0:.0f} s",
            "- peer: CAPD's Python bindings "
            + (f"`uj-capdpy` {_capd_version()} (module capdpy)" if capd else "NOT INSTALLED")
            + ", double intervals, `IOdeSolver` + `ITimeMap` on a `C0HOTripletonSet`",
            f"- CPU time (`time.process_time`), best of {a.repeat}, contenders interleaved (forward "
            "and backward in turn), "
            "compilation excluded, BLAS on one thread; both tools run the same merged quadratic "
            "field from the same initial box; every box contains the 200-bit Arb reference",
            "- tstarg: `interval_body_enclosure(..., tol=tol)` at `order = default_order(tol)`, "
            "`jac_order = 6`; `CPU call` = the whole call, `CPU field` = from the ball field "
            "(`interval_tables` + `interval_enclose`), as CAPD starts from its formula",
            "- ratio = tstarg's CPU / CAPD's at equal radius (tstarg row: over the cheapest CAPD run "
            "at least as tight; CAPD row: the cheapest tstarg run at least as tight, over it); "
            "`CPU call` first, `CPU field` in brackets; < 1: tstarg is faster",
            "",
        ]
        with open(a.write, "w") as fh:
            fh.write("\n".join(head + _summary(rows) + [""] + lines) + "\n")
    return 0 if rows else 1


@pytest.mark.slow
def test_bench_capd():
    """The whole comparison (slow): every box contains the reference, every tstarg radius is finite
    and shrinks with tol down to the double floor."""
    rows = run()
    for name in _problems():
        for T in TIMES:
            rads = [r[5] for r in rows if r[0] == name and r[1] == T and r[2] == "tstarg"]
            assert all(np.isfinite(rads)) and rads[-1] < rads[0], (name, T, rads)


if __name__ == "__main__":
    sys.exit(main())
