"""Where the su(2) protocol flow's time goes (issue 25), as a script.

    python tests/benchmarks/su2_profile.py [--problems heavy,lagrange] [--repeats 20] [--T 100]

For the heavy asymmetric top of the committed bench (reports._bench_protocol ``heavy_top_full``:
I = diag(1, 1.3, 0.6), L = (0.2, 0.1, 1)) and the Lagrange top (I = diag(1, 1, 0.5), L = e3), both at
T = 100 (``--T``) from x0 = (0.1, 0.2, 0), pi0 = (0.3, 0.2, 2), gamma = -e3 (issue 25's table), one
trajectory:

* ``flow``: the whole protocol call ``tstarg.refimpl.fast.implementation.flow`` at its default
  accuracy, and its error against heyoka in long double at tol 1e-19 (the bench's method);
* ``pair``: the unrolled pair kernel alone (:func:`refimpl._compiled_taylor.unrolled_pair`: the first
  pair's two runs on the two lanes of one vector) at the first pair's local tolerances and order
  (:func:`refimpl._flow_compiled.local_tolerances`, :func:`refimpl._flow_compiled._order_b`); ``glue`` =
  flow - pair (validation, start, estimate, logarithm); ``run A`` and ``run B``: the single kernel
  alone at each tolerance, with their step counts (what the pair saves);
* heyoka ``taylor_adaptive`` (full mode) at the loosest quarter-decade tolerance whose error is at or
  below ours (``reports._bench_protocol._walk``: the rung charged) and at the next looser rung.

CPU time (``time.process_time``), contenders interleaved, best of ``--repeats`` rounds of :data:`INNER` calls;
compilation excluded. Needs heyoka (the bench extra). Write the load (``uptime``) next to the figures.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from tstarg.refimpl import _compiled_taylor as CT  # noqa: E402
from tstarg.refimpl import _flow_compiled as FC  # noqa: E402
from tstarg.refimpl.fast import implementation as FAST  # noqa: E402
from tstarg.refimpl.flows import cached_model  # noqa: E402
from tstarg.reports import _bench_protocol as bp  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from su2_estimate_constants import prob  # noqa: E402

INNER = 20  # calls per timed round: the first after another contender's run pays its cache misses


def problem(name: str, T: float = 100.0) -> bp.ProtocolProblem:
    if name == "heavy":
        if T == 100.0:
            return bp.protocol_problem("heavy_top_full")
        return prob("heavy", np.diag([1.0, 1.3, 0.6]), [0.2, 0.1, 1.0], T=T)
    if name == "lagrange":
        return prob("lagrange", np.diag([1.0, 1.0, 0.5]), [0.0, 0.0, 1.0], T=T)
    raise ValueError(f"--problems: unknown problem {name!r} (heavy, lagrange)")


def profile(name: str, repeats: int, T: float = 100.0) -> dict:
    p = problem(name, T)
    print(f"[{name}] reference (heyoka long double, tol 1e-19) ...", flush=True)
    ref_ta = bp.heyoka_taylor(p, 1e-19, fp="longdouble", compact=True)
    ref_ta.propagate_until(np.longdouble(p.T))
    ref = np.array(ref_ta.state, dtype=np.longdouble)
    args = p.args()
    x, pi = FAST.flow(*args)
    e_ours = bp.ours_error(p, x, pi, ref)
    m = cached_model(p.f, p.theta, p.upsilon, p.inertia, p.potential)
    cf = m.compiled_full_field
    y0 = np.empty((1, 10))
    FC._start(p.x0[:, None].copy(), p.pi0[:, None].copy(), m.gamma, True, y0)
    eps_a, eps_b = FC.local_tolerances(FAST.flow_tolerance, FC.A_LOOSE_FULL)
    P = FC._order_b(cf, eps_b)
    kern = CT.unrolled_adaptive(cf, P)
    pair = CT.unrolled_pair(cf, P)
    out, st = np.empty_like(y0), np.empty(1, dtype=np.int64)
    outb, stb = np.empty_like(y0), np.empty(1, dtype=np.int64)
    steps = {}

    def run(eps):
        kern(y0, p.T, eps, FC.MAX_STEPS, cf.qcoef, cf.lcoef, out, st)

    def run_pair():
        pair(y0, p.T, eps_a, eps_b, FC.MAX_STEPS, cf.qcoef, cf.lcoef, out, outb, st, stb)

    for key, eps in (("A", eps_a), ("B", eps_b)):
        run(eps)
        steps[key] = int(st[0])
    print(f"[{name}] heyoka's grid (full mode) around our error {e_ours:.2e} ...", flush=True)
    grid = bp.grid_tolerances()

    def hey_err(tol):
        ta = bp.heyoka_taylor(p, tol, compact=False)
        s = bp.run_heyoka_state(p, ta, p.y0())
        return bp.protocol_error(p, s[: p.n], s[p.n :], ref)

    errs, meet = bp._walk(hey_err, grid, e_ours, want=1)
    k = (
        meet[0] if meet else min(errs, key=errs.get)
    )  # most accurate rung if none meets (our favour)
    rungs = [k] + ([k - 1] if k - 1 in errs else [])
    calls = {
        "flow": lambda: FAST.flow(*args),
        "run A": lambda: run(eps_a),
        "run B": lambda: run(eps_b),
        "pair": run_pair,
    }
    hy0 = p.y0()  # heyoka's starting state, once: its expm is not heyoka's work
    for i in rungs:
        ta = bp.heyoka_taylor(p, grid[i], compact=False)
        calls[f"heyoka {grid[i]:.2e}"] = lambda ta=ta: bp.run_heyoka_state(p, ta, hy0)
    best = dict.fromkeys(calls, np.inf)
    for r in range(repeats):
        for key, fn in calls.items():
            t0 = time.process_time()
            for _ in range(INNER):
                fn()
            best[key] = min(best[key], (time.process_time() - t0) / INNER)
        print(f"\r[{name}] timing {r + 1}/{repeats}", end="", flush=True)
    print()
    us = {key: v * 1e6 for key, v in best.items()}
    glue = us["flow"] - us["pair"]
    print(
        f"[{name}] flow {us['flow']:.1f} us (error {e_ours:.2e}) = pair {us['pair']:.1f} (A and B "
        f"on two lanes; alone: run A {us['run A']:.1f}, eps {eps_a:.0e}, order {P}, {steps['A']} "
        f"steps; run B {us['run B']:.1f}, eps {eps_b:.0e}, {steps['B']} steps) + glue {glue:.1f}"
    )
    for i in rungs:
        t = us[f"heyoka {grid[i]:.2e}"]
        tag = "charged" if i == k else "next looser, misses"
        print(
            f"[{name}] heyoka tol {grid[i]:.2e} ({tag}): {t:.1f} us, error {errs[i]:.2e} | "
            f"ratio {us['flow'] / t:.2f}"
        )
    return {"name": name, "us": us, "error": e_ours, "charged": grid[k]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", default="heavy,lagrange")
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--T", type=float, default=100.0, help="the time span (issue 25's table: 100)")
    args = ap.parse_args(argv)
    for name in args.problems.split(","):
        profile(name, args.repeats, args.T)
    return 0


if __name__ == "__main__":
    sys.exit(main())
