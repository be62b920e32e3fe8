"""The worker of ``tstarg bench`` (:mod:`reports.cmd_bench` parses the arguments and calls :func:`main`).

1. Flows on su(2) (heavy top, free asymmetric top; body systems, t = 100): every method of
   :data:`refimpl.flows.METHODS` that applies, over a ladder of step counts, and scipy's
   ``solve_ivp`` (DOP853, RK45, Radau) over a ladder of ``rtol = atol``, scipy given the generated
   scalar right-hand side; Radau gets no Jacobian (scipy's finite differences). Error: the worst
   component against the mpmath reference; time: minimum of repeats after a warm-up. Pareto front
   marked; the best tstarg method's time over DOP853's at errors 1e-6, 1e-9, 1e-12.
2. The protocol flow on every algebra (:mod:`reports._bench_protocol`): se(3), so(4), su(3), a
   Bianchi algebra with a cocycle, a model with Theta and Upsilon, the heavy top's full state; our
   ``flow`` at its default accuracy against heyoka at equal error, one trajectory and a batch.
3. Brackets: the Poisson tensor by the fast float64 batch and by the mpmath reference at several
   precisions, error against a high-precision reference, time per point.
4. Batch throughput: time per trajectory for 1, 10^2, 10^4 trajectories against scipy DOP853
   looped per trajectory (timed on a subsample), and against heyoka's batch mode.

References and error evaluations run through :func:`reports._parallel.map_tasks` (``--workers``,
``--scheduler``); every timing runs serially in this process. Writes ``report.json``,
``report.md`` and PNG figures into ``--out``.
"""

from __future__ import annotations

import json
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import mpmath
import numpy as np
import scipy
from threadpoolctl import threadpool_info, threadpool_limits

from tstarg.refimpl import COMPILED_PATH, catalogue, compile_count, provides
from tstarg.refimpl.fast import Fast
from tstarg.refimpl.flows import METHODS, method

from . import _bench_protocol as bp
from . import _workprecision as wp
from ._atomic import claim_output, write_text
from ._imports import import_module, resolve
from ._parallel import describe, map_tasks, parallel_options
from ._progress import Progress, is_quiet
from ._workprecision import fmt_err, fmt_time
from .environment import git_commit
from .jsonl import CommandImplementation, ProgramFailure, check_timeout


def _env() -> dict:
    import matplotlib  # heavy: loaded only when a report is written

    return {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "cpu_count": os.cpu_count(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "mpmath": mpmath.__version__,
        "mpmath_backend": mpmath.libmp.BACKEND,
        "matplotlib": matplotlib.__version__,
        "blas_threads": [(i.get("internal_api"), i.get("num_threads")) for i in threadpool_info()],
        "git_commit": git_commit(),  # the one source of the commit (reports.environment)
        "git_uncommitted_changes": _git_dirty(),
    }


def _git_dirty() -> bool | None:
    """Whether the working tree differs from the commit (read-only ``git status --porcelain``)."""
    try:
        r = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=20,
            check=False,
            cwd=Path(__file__).resolve().parent,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return bool(r.stdout.strip()) if r.returncode == 0 else None


def _settings(quick: bool) -> dict:
    if quick:
        return {
            "steps_per_time": 1.25,
            "doublings": 3,
            "rtols": [1e-3, 1e-5, 1e-7, 1e-9],
            "floor": 1e-11,
            "nfev_cap": 20000,
            "target_cap": 1e-3,
            "ref_dps": 16,
            "ref_check": False,
            "batch_sizes": [1, 10, 100],
            "batch_target": 1e-6,
            "scipy_sub": 3,
            "bracket_dps": [15],
            "bracket_high": 30,
            "rounds": 3,
            "protocol_batch": 40,
            "protocol_sample": 4,
            "protocol_modes": (True,),
        }
    return {
        "steps_per_time": 1.25,
        "doublings": 6,
        "rtols": [10.0**-k for k in range(3, 14)] + [2.5e-14],
        "floor": 1e-13,
        "nfev_cap": 60000,
        "target_cap": 1e-6,
        "ref_dps": 20,
        "ref_check": True,
        "batch_sizes": [1, 100, 10000],
        "batch_target": 1e-8,
        "scipy_sub": 20,
        "bracket_dps": [15, 30, 50, 100],
        "bracket_high": 150,
        "rounds": 7,
        "protocol_batch": 10000,
        "protocol_sample": 64,
        "protocol_modes": (False, True),
    }


TIMING_NOTE = (
    "timings run serially in the main process (never in parallel: two processes on two shared "
    "cores would distort each other); each method warmed up by one untimed run, then the minimum "
    "of 7 repeats (runs < 0.1 s; 3 with --quick), 3 (< 1 s) or 1, rounds interleaved over all points; "
    "time = CPU "
    "time of the process (time.process_time: single-threaded runs, so equal to the wall time on an "
    "idle machine, and undisturbed by other processes on a shared one), wall-clock minima recorded "
    "too; BLAS pinned to 1 thread"
)


def main(args) -> int:
    threadpool_limits(1)

    t_start = time.perf_counter()
    try:
        parallel_options(args)  # a bad --workers/--scheduler is refused here, by name
        problems = (
            []
            if args.problems == "none"
            else args.problems.split(",")
            if args.problems
            else list(wp.FLOW_PROBLEMS)
        )
        for name in problems:
            wp.flow_problem(name)
        method(args.batch_method)
        protocol = _protocol_names(args)
        if args.protocol_batch is not None and args.protocol_batch < 1:
            raise ValueError(
                f"--protocol-batch must be at least 1 trajectory, got {args.protocol_batch}"
            )
        for path in getattr(args, "reuse", None) or []:
            if not Path(path).is_file():
                raise ValueError(f"--reuse {path!r}: no such report.json")
        contender = _load_contender(args)
    except ValueError as exc:
        print(f"tstarg bench: {exc}", file=sys.stderr)
        return 2
    try:
        with Progress("bench", quiet=is_quiet(args)) as display:
            return _main(args, problems, protocol, contender, t_start, display)
    finally:
        if contender is not None:
            contender.close()


def _protocol_names(args) -> list[str]:
    """The ``--protocol-problems`` (validated), default all (``--quick``: one small one); ``none``: no section."""
    spec = getattr(args, "protocol_problems", None)
    if spec is None:
        return list(bp.PROTOCOL_QUICK if args.quick else bp.PROTOCOL_PROBLEMS)
    if spec.strip() == "none":
        return []
    names = [n.strip() for n in spec.split(",") if n.strip()]
    for n in names:
        bp.protocol_problem(n)  # an unknown name is refused here, with the known ones
    return names


def _main(args, problems, protocol, contender, t_start, display: Progress) -> int:
    """The run; ``display`` shows each step (every step over ~2 s has a line or a heartbeat)."""
    opts = parallel_options(args)
    S = _settings(args.quick)
    if args.ref_dps is not None:
        if args.ref_dps < 15:
            print(f"tstarg bench: --ref-dps must be >= 15, got {args.ref_dps}", file=sys.stderr)
            return 2
        S["ref_dps"] = args.ref_dps
    out = claim_output(Path(args.out))  # a concurrent run gets its own folder and says so
    out.mkdir(parents=True, exist_ok=True)
    display.note(
        f"tstarg bench{' --quick' if args.quick else ''}: references and error ladders on "
        f"{describe(**opts)}; {TIMING_NOTE}"
    )
    report = {
        "command": "tstarg " + " ".join(sys.argv[1:])
        if sys.argv and Path(sys.argv[0]).name == "tstarg"
        else "tstarg bench " + " ".join(_argv(args)),
        "quick": bool(args.quick),
        "settings": S,
        "parallel": describe(**opts),
        "timing": TIMING_NOTE,
        "loadavg_start": list(os.getloadavg()),
        "environment": _env(),
        "flows": {},
    }

    # ---- 1. flows: references, error ladders (parallel), timings (serial)
    if problems:
        display.phase(f"references of {', '.join(problems)} (mpmath, in parallel)")
    refs = map_tasks(
        wp.reference_task,
        [(n, args.quick, S["ref_dps"], S["ref_check"]) for n in problems],
        **opts,
        on_result=display.callback(
            lambda i, v: f"reference {v['problem']}", lambda i, v: f"{v['seconds']:.1f} s"
        ),
    )
    heyoka = wp.have_heyoka() and not args.no_heyoka
    report["compiled_path"] = COMPILED_PATH
    report["heyoka"] = f"heyoka {wp.heyoka_version()}" if heyoka else "not included"
    items, skipped = [], {}
    for name, ref in zip(problems, refs):
        p = wp.flow_problem(name, args.quick)
        names, skipped[name] = wp.fast_methods(p.model())
        n0 = max(4, round(S["steps_per_time"] * p.T))
        n_max = n0 * 2 ** S["doublings"]
        if args.methods:
            wanted = args.methods.split(",")
            unknown = [m for m in wanted if m not in names and m not in skipped[name]]
            if unknown:
                print(f"tstarg bench: unknown flow methods {unknown}", file=sys.stderr)
                return 2
            names = [m for m in names if m in wanted]
        for m in names:
            if METHODS[m].adaptive:
                ladder = wp.tol_ladder(args.quick)
            else:
                ladder = wp.step_ladder(getattr(METHODS[m], "order", None), n0, n_max)
            items.append(
                (
                    name,
                    args.quick,
                    "fast",
                    m,
                    ladder,
                    ref["values"],
                    S["floor"],
                    S["nfev_cap"],
                    S["target_cap"],
                )
            )
        if heyoka:  # Upsilon != 0: the rational field of wp.heyoka_rational_rhs
            items.append(
                (
                    name,
                    args.quick,
                    "heyoka",
                    "taylor_adaptive",
                    wp.tol_ladder(args.quick),
                    ref["values"],
                    S["floor"],
                    S["nfev_cap"],
                    S["target_cap"],
                )
            )
        for s in wp.SCIPY_SOLVERS:
            items.append(
                (
                    name,
                    args.quick,
                    "scipy",
                    s,
                    S["rtols"],
                    ref["values"],
                    S["floor"],
                    S["nfev_cap"],
                    S["target_cap"],
                )
            )
        display.note(f"  {name}: reference {ref['how']} ({ref['seconds']:.1f} s)")
    if items:
        display.phase(f"error ladders of {len(items)} methods (in parallel)")
    ladders = map_tasks(
        wp.ladder_task,
        items,
        **opts,
        on_result=display.callback(
            lambda i, v: f"error ladder {v['kind']} {v['method']} on {v['problem']}",
            lambda i, v: f"{len(v['points'])} points; {v['stop']}",
        ),
    )
    if contender is not None:
        report["impl"] = contender.describe()
    for name, ref in zip(problems, refs):
        display.start(f"timing {name} (every point, serially, interleaved)")
        extra = () if contender is None else contender.flow_rows(name, args.quick, ref, S)
        report["flows"][name] = _time_flow(
            name,
            args.quick,
            ref,
            [l for l in ladders if l["problem"] == name],
            skipped[name],
            out,
            S["rounds"],
            extra=extra,
        )
        if contender is not None:
            contender.flow_ratios(name, report["flows"][name])
        display.done(None, f"{len(report['flows'][name]['points'])} points")
        _print_flow(report["flows"][name], display)
    report["compile"] = {
        "tstarg": {
            **compile_count(),
            "path": COMPILED_PATH,
            "note": "numba kernels per field structure and order, cached on disk: "
            "'compiled' were built in this run, 'loaded' came from the cache",
        },
        "heyoka": {f"{k[0]} tol={k[2]:g}": v for k, v in wp.HEYOKA_COMPILE.items()},
    }

    # ---- 2. the protocol flow on every algebra against heyoka
    if protocol and not heyoka:
        display.note(
            "  protocol-flow section skipped: heyoka is not included (the peer it measures against)"
        )
    elif protocol:
        M = args.protocol_batch if args.protocol_batch is not None else S["protocol_batch"]
        report["protocol"] = _protocol(args.quick, S, opts, protocol, M, display)

    # ---- 3. brackets
    if not args.no_brackets:
        display.phase("brackets: errors (in parallel) and times (serially)")
        report["brackets"] = _brackets(
            args.quick,
            S,
            opts,
            out,
            extra=None if contender is None else contender.bracket_rows(args.quick, S, opts),
        )
        if contender is not None:
            contender.bracket_ratios(report["brackets"])
        for row in report["brackets"]["summary"]:
            display.note(
                f"  brackets {row['algebra']:6s} {row['method']:28s} worst error {wp.fmt_err(row['error'])} "
                f"time/point {wp.fmt_time(row['time_per_point'])}"
            )

    # ---- 4. batch throughput
    if not args.no_batch and "heavy_top" in report["flows"]:
        if args.batch_method not in {r["method"] for r in report["flows"]["heavy_top"]["points"]}:
            display.note(
                f"  batch throughput skipped: --batch-method {args.batch_method} was not benchmarked on the heavy top"
            )
        else:
            display.phase("batch throughput: 1, 10^2, 10^4 trajectories against scipy")
            report["batch"] = _batch(
                args.quick,
                S,
                opts,
                report["flows"]["heavy_top"],
                refs[problems.index("heavy_top")],
                out,
                args.batch_method,
            )
            for r in report["batch"]["rows"]:
                display.note(
                    f"  batch M={r['M']:>6d}: ours {wp.fmt_time(r['ours_per_traj'])}/traj, scipy DOP853 loop "
                    f"{wp.fmt_time(r['scipy_per_traj'])}/traj, time ratio ours/scipy {r['ratio']:.3g}"
                )
            if heyoka:
                display.phase("the largest batch against heyoka's taylor_adaptive_batch")
                report["batch_heyoka"] = _batch_heyoka(
                    args.quick, S, report["batch"]["method"], report["batch"]["steps"]
                )
                for r in report["batch_heyoka"]["rows"]:
                    display.note(
                        f"  batch vs heyoka M={r['M']}: {r['label']}: worst error {wp.fmt_err(r['worst'])}, "
                        f"{wp.fmt_time(r['per_traj'])}/traj, ratio to heyoka {r['ratio']:.3g}"
                    )

    for path in getattr(args, "reuse", None) or []:
        _reuse(report, Path(path), out)
    report["loadavg_end"] = list(os.getloadavg())
    report["seconds"] = time.perf_counter() - t_start
    display.phase("writing the report")
    write_text(
        out / "report.json",
        json.dumps(_finite(report), indent=1, default=_json_default, allow_nan=False),
    )
    write_text(out / "report.md", render_markdown(report))
    display.note(
        f"wrote {out / 'report.json'}, {out / 'report.md'} and figures ({report['seconds']:.0f} s)"
    )
    return 0


REUSABLE = ("flows", "protocol", "brackets", "batch", "batch_heyoka")


def _reuse(report: dict, path: Path, out: Path) -> None:
    """Fill the sections this run did not measure from an earlier ``report.json`` (``--reuse``), copy
    their figures into ``out``, and record in ``report["reused"]`` which sections came from which run
    (its command, commit, start time load); ratios are only ever formed within one run."""
    try:
        old = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ValueError(
            f"--reuse {str(path)!r}: cannot read an earlier report.json: {exc}"
        ) from None
    reused = report.setdefault("reused", {})
    for key in REUSABLE:
        if report.get(key) or not old.get(key):
            continue
        report[key] = old[key]
        reused[key] = old.get("reused", {}).get(key) or {  # a chain keeps the measuring run
            "command": old.get("command"),
            "git_commit": old.get("environment", {}).get("git_commit"),
            "loadavg_start": old.get("loadavg_start"),
        }
        figs = {
            "flows": [f.get("figure") for f in old[key].values()] if key == "flows" else [],
            "brackets": old[key].get("figures", []) if key == "brackets" else [],
            "batch": [old[key].get("figure")] if key == "batch" else [],
        }.get(key, [])
        for fig in filter(None, figs):
            src, dst = path.parent / fig, out / fig
            if src.resolve() != dst.resolve() and src.exists():
                dst.write_bytes(src.read_bytes())
        if key == "flows" and "compile" in old:
            report["compile"] = old["compile"]


def _argv(args) -> list[str]:
    parts = []
    for k in (
        "out",
        "problems",
        "methods",
        "ref_dps",
        "batch_method",
        "workers",
        "scheduler",
        "impl",
        "cmd",
        "protocol_problems",
        "protocol_batch",
        "reuse",
    ):
        v = getattr(args, k, None)
        for x in v if isinstance(v, list) else [v]:
            if x is not None and not (k == "batch_method" and x == "taylor20"):
                parts += [f"--{k.replace('_', '-')}", str(x)]
    for k in ("quick", "no_brackets", "no_batch", "no_heyoka"):
        if getattr(args, k, False):
            parts.append(f"--{k.replace('_', '-')}")
    return parts


def _finite(o):
    """Strict JSON: non-finite floats (a diverged run's error, a time never measured) become null."""
    if isinstance(o, float) and not math.isfinite(o):
        return None
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    return o


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def _time_flow(name, quick, ref, ladders, skipped, out, rounds, extra=()) -> dict:
    p = wp.flow_problem(name, quick)
    model = p.model()
    rhs, rhs_how = wp.scipy_rhs(model)
    fixed = [  # step ladders only: an adaptive method's ladder holds tolerances, not step counts
        l["ladder"]
        for l in ladders
        if l["kind"] == "fast" and l["ladder"] and not METHODS[l["method"]].adaptive
    ]
    ladder_range = [min(x[0] for x in fixed), max(x[-1] for x in fixed)] if fixed else None
    tols = sorted(
        {
            t
            for l in ladders
            if l["kind"] == "heyoka" or (l["kind"] == "fast" and METHODS[l["method"]].adaptive)
            for t in l["ladder"]
        },
        reverse=True,
    )
    calls, rows = [], []
    for lad in ladders:
        for pt in lad["points"]:
            if lad["kind"] == "fast":
                calls.append(lambda m=lad["method"], s=pt["setting"]: wp.run_fast(p, model, m, s))
                rows.append(
                    {
                        "method": lad["method"],
                        "family": "tstarg",
                        "setting_name": "tol" if METHODS[lad["method"]].adaptive else "steps",
                        **pt,
                    }
                )
            elif lad["kind"] == "heyoka":
                wp.heyoka_integrator(
                    p, model, pt["setting"]
                )  # JIT-compile before timing (reported apart)
                calls.append(lambda s=pt["setting"]: wp.run_heyoka(p, model, s))
                rows.append(
                    {
                        "method": "heyoka taylor_adaptive",
                        "family": "heyoka",
                        "setting_name": "tol",
                        **pt,
                    }
                )
            else:
                calls.append(lambda m=lad["method"], s=pt["setting"]: wp.run_scipy(p, rhs, m, s))
                rows.append(
                    {
                        "method": f"scipy {lad['method']}",
                        "family": "scipy",
                        "setting_name": "rtol=atol",
                        **pt,
                    }
                )
    for row, call in extra:  # a third-party contender (--impl/--cmd), timed interleaved with ours
        rows.append(row)
        calls.append(call)
    for row, tm in zip(
        rows, wp.time_points(calls, groups=[r["method"] for r in rows], max_rounds=rounds)
    ):
        row.update(tm)
    race = None
    if (
        model.upsilon_zero
    ):  # is the scalar rhs really scipy's best? race it against the numpy body field
        F = model.body_rhs()

        def numpy_rhs(t, y):
            return F(y[:, None])[:, 0]

        tr = wp.time_points(
            [
                lambda: wp.run_scipy(p, rhs, "DOP853", 1e-8),
                lambda: wp.run_scipy(p, numpy_rhs, "DOP853", 1e-8),
            ]
        )
        race = {
            "scalar": tr[0]["time"],
            "numpy": tr[1]["time"],
            "setting": "DOP853, rtol = atol = 1e-8",
        }
    front = wp.pareto_front([r["time"] for r in rows], [r["error"] for r in rows])
    for row, f in zip(rows, front):
        row["on_front"] = bool(f)
    ratios = []
    tstarg = sorted({r["method"] for r in rows if r["family"] == "tstarg"})
    dop_errors = [
        r["error"] for r in rows if r["method"] == "scipy DOP853" and math.isfinite(r["error"])
    ]
    targets = [(t, f"{t:.0e}") for t in wp.ERROR_TARGETS]
    if dop_errors:
        targets.append((min(dop_errors), f"{min(dop_errors):.2e} (DOP853's finest)"))
    for tgt, label in targets:
        per = {}
        for m in tstarg + [f"scipy {s}" for s in wp.SCIPY_SOLVERS] + ["heyoka taylor_adaptive"]:
            pts = [r for r in rows if r["method"] == m]
            per[m] = wp.time_at_error([r["time"] for r in pts], [r["error"] for r in pts], tgt)
        reached = {m: t for m, t in per.items() if m in tstarg and math.isfinite(t)}
        best = min(reached, key=reached.get) if reached else None
        t_dop = per.get("scipy DOP853", math.nan)
        ratio = reached[best] / t_dop if best and math.isfinite(t_dop) else None
        t_hy = per.get("heyoka taylor_adaptive", math.nan)
        ratio_hy = reached[best] / t_hy if best and math.isfinite(t_hy) else None
        ratios.append(
            {
                "target": tgt,
                "label": label,
                "best_tstarg": best,
                "t_best": reached.get(best) if best else None,
                "t_dop853": t_dop if math.isfinite(t_dop) else None,
                "ratio_best_over_dop853": ratio,
                "t_heyoka": t_hy if math.isfinite(t_hy) else None,
                "ratio_best_over_heyoka": ratio_hy,
                "times": {m: (t if math.isfinite(t) else None) for m, t in per.items()},
                "note": ""
                if ratio is not None
                else ("not reached by tstarg" if best is None else "not reached by DOP853"),
            }
        )
    fig = f"{name}_wp.png"
    wp.plot_work_precision(
        rows, out / fig, f"{p.title}, t = {p.T:g}: error vs time (one trajectory)"
    )
    return {
        "title": p.title,
        "T": p.T,
        "reference": {k: ref[k] for k in ("how", "values", "digits", "seconds")},
        "scipy_rhs": rhs_how,
        "scipy_rhs_race": race,
        "radau_jacobian": "none supplied (scipy's finite-difference Jacobian)",
        "skipped": skipped,
        "ladder": ladder_range,
        "tol_ladder": tols,
        "stops": {f"{l['kind']} {l['method']}": l["stop"] for l in ladders},
        "points": rows,
        "ratios": ratios,
        "figure": fig,
    }


def _protocol(
    quick: bool, S: dict, opts: dict, names: list[str], M: int, display: Progress
) -> dict:
    """The protocol flow against heyoka on each problem (:mod:`reports._bench_protocol`): the judges
    (real128 end states, long-double batch samples) in parallel, then every timing serially."""
    K = min(S["protocol_sample"], M)
    root = Path(
        os.environ.get("TSTARG_CACHE_DIR") or Path("~/.cache/tstarg").expanduser()
    )  # where refimpl keeps its compiled kernels ($TSTARG_CACHE_DIR)
    cache = {
        "dir": str(root),
        "files_at_start": sum(1 for q in root.rglob("*") if q.is_file()) if root.is_dir() else 0,
    }
    display.phase(
        f"protocol flow: judges of {', '.join(names)} (heyoka real128; batch samples of {K} in "
        "long double; in parallel)"
    )
    refs = map_tasks(
        bp.reference_task,
        [(n, quick) for n in names],
        **opts,
        on_result=display.callback(
            lambda i, v: f"protocol judge {v['problem']}", lambda i, v: v["how"]
        ),
    )
    samples = map_tasks(
        bp.batch_reference_task, [(n, quick, M, j) for n in names for j in range(K)], **opts
    )
    out: dict = {}
    for i, (name, ref) in enumerate(zip(names, refs)):
        display.start(f"protocol flow {name}: one trajectory (ours, heyoka's grid)")
        r = bp.measure_problem(name, quick, ref, S["rounds"], modes=S["protocol_modes"])
        best = r["heyoka_best"]
        hy_txt = (
            f"heyoka {fmt_time(best['time'])} at tol {best['tol']:.2e} "
            f"({'compact' if best['compact_mode'] else 'full'} mode, error {fmt_err(best['error'])}): "
            f"ratio {r['ratio']:.3g}"
            if best
            else r["note"]
        )
        display.done(
            None,
            f"ours {fmt_time(r['ours']['time'])}, error {fmt_err(r['ours']['error'])}; {hy_txt}",
        )
        display.start(f"protocol flow {name}: batch of {M}")
        compact = best["compact_mode"] if best else True
        try:
            r["batch"] = bp.measure_batch(
                name, quick, M, samples[i * K : (i + 1) * K], min(3, S["rounds"]), compact
            )
        except ValueError as exc:  # the flow refused the batch (e.g. its time budget): said so
            r["batch"] = {"M": M, "refused": f"{type(exc).__name__}: {exc}"}
            display.done(None, f"batch refused: {exc}")
            out[name] = r
            continue
        b = r["batch"]
        display.done(
            None,
            f"ours {fmt_time(b['ours']['per_traj'])}/traj (worst sampled error "
            f"{fmt_err(b['ours']['error'])}); "
            + (
                f"heyoka {fmt_time(b['heyoka_best']['time'] / M)}/traj: ratio {b['ratio']:.3g}"
                if b["heyoka_best"]
                else "heyoka's grid does not reach our error"
            ),
        )
        out[name] = r
    return {
        "problems": out,
        "M": M,
        "sample": K,
        "kernel_cache": cache,
        "time_budget_s": os.environ.get("TSTARG_TIME_BUDGET_S", "default"),
        "compile_heyoka": {
            f"{k[0]} {k[2]} tol={k[3]} {'compact' if k[4] else 'full'}"
            + (f" batch width {k[5]}" if k[5] else ""): v
            for k, v in bp.COMPILE.items()
        },
        "note": (
            "ours: refimpl.fast.implementation.flow at its default accuracy on the full state (x, pi), "
            "error max(|pi - pi_ref|, |Ad(exp x) - R_ref|); heyoka: taylor_adaptive on (pi, R = Ad(g)) "
            "generated from the same model (reports._bench_protocol.heyoka_system), charged its cheapest "
            "tolerance on the quarter-decade grid 10^(-k/4) whose error is at or below ours, the faster "
            "of its two code-generation modes (compact_mode off/on); judge: heyoka real128 at tol 1e-30; "
            "CPU time, contenders interleaved, best of repeats, compilation excluded (our first call and "
            "heyoka's JIT reported apart); batch: M trajectories (x0 + 0.01 N, pi0 + 0.01 N, seed 3), "
            "ours one batched flow call, heyoka taylor_adaptive_batch at its recommended SIMD width in "
            "the mode that won the single trajectory, errors the worst of the first K trajectories "
            "against heyoka long double at tol 1e-19"
        ),
    }


def _print_flow(res, display: Progress) -> None:
    display.note(
        f"  {res['title']}: {len(res['points'])} points, "
        f"{sum(r['on_front'] for r in res['points'])} on the Pareto front"
    )
    for r in res["ratios"]:
        if r["ratio_best_over_dop853"] is not None:
            hy = (
                ""
                if r.get("ratio_best_over_heyoka") is None
                else (
                    f"; heyoka {fmt_time(r['t_heyoka'])}: ratio {r['ratio_best_over_heyoka']:.3g}"
                )
            )
            display.note(
                f"    error {r['label']}: best tstarg {r['best_tstarg']} {fmt_time(r['t_best'])}, "
                f"scipy DOP853 {fmt_time(r['t_dop853'])}: ratio {r['ratio_best_over_dop853']:.3g}{hy}"
            )
        else:
            display.note(f"    error {r['label']}: {r['note']}")


def _fast_path(case: dict) -> str:
    """The ``path`` of the fast implementation's Poisson tensor on a bracket case (names the kernels)."""
    f = catalogue(case["algebra"]).f
    return (
        Fast().poisson_batch(f, case["theta"], case["upsilon"], case["x"][:1], case["pi"][:1]).path
    )


def _brackets(quick, S, opts, out, extra=None) -> dict:
    cases = wp.bracket_cases(quick)
    methods = [
        ("fast batch", "fast", None, "closed"),
        ("fast, one call per point", "fast-single", None, "closed"),
        (f"fast batch of {wp.TILED} (points tiled)", "fast-tiled", None, "closed"),
    ]
    methods += [(f"reference closed dps={d}", "reference", d, "closed") for d in S["bracket_dps"]]
    methods += [
        (
            f"reference first_principles dps={S['bracket_dps'][0]}",
            "reference",
            S["bracket_dps"][0],
            "first_principles",
        )
    ]
    items, keys = [], []
    for ci, case in enumerate(cases):
        for label, kind, dps, route in methods:
            if kind in ("fast-single", "fast-tiled"):
                continue  # the same numbers as the batch at the same points
            for j in range(len(case["x"])):
                items.append(
                    (
                        ci,
                        quick,
                        j,
                        "fast" if kind == "fast" else "reference",
                        dps,
                        route,
                        S["bracket_high"],
                    )
                )
                keys.append((ci, label))
    errs = map_tasks(wp.bracket_error_task, items, **opts)
    worst: dict = {}
    for k, e in zip(keys, errs):
        worst[k] = max(worst.get(k, 0.0), e)
    calls, rows = [], []
    for ci, case in enumerate(cases):
        for label, kind, dps, route in methods:
            calls.append(wp.bracket_call(case, kind, dps, route))
            err = worst[(ci, "fast batch" if kind in ("fast-single", "fast-tiled") else label)]
            rows.append(
                {
                    "algebra": case["algebra"],
                    "method": label,
                    "dps": dps,
                    "route": route,
                    "error": err,
                    "points": wp.TILED if kind == "fast-tiled" else len(case["x"]),
                    "family": "tstarg" if kind.startswith("fast") else "reference",
                }
            )
    if extra is not None:  # a third-party contender (--impl/--cmd): its rows and timed calls
        xrows, xcalls = extra(cases)
        rows += xrows
        calls += xcalls
    for row, tm in zip(rows, wp.time_points(calls, max_rounds=min(5, S["rounds"]))):
        row.update(tm)
        row["time_per_point"] = tm["time"] / row["points"]
    figs = []
    for case in cases:
        pts = [
            {**r, "time": r["time_per_point"], "method": r["method"].split(" dps=")[0]}
            for r in rows
            if r["algebra"] == case["algebra"]
        ]
        front = wp.pareto_front([r["time"] for r in pts], [max(r["error"], 1e-300) for r in pts])
        for r, r0, f in zip(pts, [r for r in rows if r["algebra"] == case["algebra"]], front):
            r["on_front"] = r0["on_front"] = bool(f)
        fig = f"brackets_{case['algebra'].replace('(', '').replace(')', '')}_wp.png"
        wp.plot_work_precision(
            pts,
            out / fig,
            f"Poisson tensor on {case['algebra']} (vier9, holonomic): error "
            f"vs time per point, {len(case['x'])} points",
            xlabel="CPU time per point [s]",
            targets=(),
        )
        figs.append(fig)
    return {
        "error": f"max_ij |P - Pref| / max_ij |Pref| per point, worst over the points; Pref: mpmath reference "
        f"(closed route) at {S['bracket_high']} digits",
        "cases": [
            {
                "algebra": c["algebra"],
                "points": len(c["x"]),
                "xi_theta": "coboundary -xi.f",
                "upsilon": np.asarray(c["upsilon"]).tolist(),
                "fast_path": _fast_path(c),  # which kernels ran: compiled (numba) or numpy
            }
            for c in cases
        ],
        "summary": rows,
        "figures": figs,
    }


def _batch(quick, S, opts, flow, ref, out, batch_method) -> dict:
    name = "heavy_top"
    p = wp.flow_problem(name, quick)
    model = p.model()
    meth = batch_method
    tgt = S["batch_target"]
    ours = sorted((r for r in flow["points"] if r["method"] == meth), key=lambda r: r["setting"])
    steps = next((r["setting"] for r in ours if r["error"] <= tgt), ours[-1]["setting"])
    dop = sorted(
        (r for r in flow["points"] if r["method"] == "scipy DOP853"), key=lambda r: -r["setting"]
    )
    rtol = next((r["setting"] for r in dop if r["error"] <= tgt), dop[-1]["setting"])
    sub = S["scipy_sub"]
    items = [
        (name, quick, meth, steps, M, 3, ref["values"], rtol, min(sub, M)) for M in S["batch_sizes"]
    ]
    errs = map_tasks(wp.batch_error_task, items, **opts)
    rhs = wp.scipy_rhs(model)[0]
    calls, rows = [], []
    for M, e in zip(S["batch_sizes"], errs):
        x0, pi0 = wp.batch_initial(p, M, 3)
        k = min(sub, M)
        Y0 = wp.scipy_initial(p, x0, pi0, k)
        calls.append(lambda x0=x0, pi0=pi0: wp.run_fast(p, model, meth, steps, (x0, pi0)))
        calls.append(
            lambda Y0=Y0, k=k: [wp.run_scipy(p, rhs, "DOP853", rtol, Y0[:, j]) for j in range(k)]
        )
        rows.append({"M": M, "scipy_sample": k, **e})
    tms = wp.time_points(calls, groups=["ours", "scipy"] * len(rows), max_rounds=3, slow=5.0)
    for i, row in enumerate(rows):
        row["ours_time"], row["scipy_time"] = tms[2 * i]["time"], tms[2 * i + 1]["time"]
        row["ours_per_traj"] = row["ours_time"] / row["M"]
        row["scipy_per_traj"] = row["scipy_time"] / row["scipy_sample"]
        row["ratio"] = row["ours_per_traj"] / row["scipy_per_traj"]
        row["ours_label"] = f"tstarg {meth} (batched, {steps} fixed steps)"
        row["scipy_label"] = f"scipy DOP853 looped (rtol = atol = {rtol:g})"
    fig = "batch_throughput.png"
    wp.plot_batch(rows, out / fig, f"{p.title}, t = {p.T:g}: time per trajectory")
    return {
        "method": meth,
        "steps": steps,
        "scipy_rtol": rtol,
        "target": tgt,
        "rows": rows,
        "figure": fig,
        "note": (
            "initial momenta pi0 + 0.01 N(0,1) (seed 3), trajectory 0 = the reference trajectory; "
            "steps and rtol: the cheapest settings of the single-trajectory ladders reaching the "
            "target on the reference trajectory; scipy timed on a subsample and scaled per trajectory; "
            "batch errors: worst trajectory against a run with 4x the steps; for a single trajectory the "
            "batched numpy method pays its per-step overhead alone: the single-trajectory methods "
            "(dop853-scalar, taylor*) in the flow diagrams are the ones to compare there"
        ),
    }


def _batch_heyoka(quick, S, fixed_method, fixed_steps) -> dict:
    """The largest heavy-top batch against heyoka's ``taylor_adaptive_batch`` in the same run.

    Contenders: heyoka (SIMD batch, its recommended width), our adaptive ``taylor`` (per-trajectory
    step control, compiled) and our fixed-step batch method of ``_batch``. Each adaptive contender walks
    the flows' tolerance ladder and runs at the loosest tolerance whose worst trajectory is within the
    target; the judge is heyoka at tolerance 1e-16 (its disagreement with our ``taylor`` at the ladder's
    finest tolerance is reported: it bounds the judge's error plus ours there). CPU time, contenders interleaved, best
    of 3; heyoka's JIT compile time apart."""
    name = "heavy_top"
    p = wp.flow_problem(name, quick)
    model = p.model()
    M = max(S["batch_sizes"])
    tgt = S.get("batch_heyoka_target", 1e-9)
    x0, pi0 = wp.batch_initial(p, M, 3)
    Y0 = wp.scipy_initial(p, x0, pi0, M)
    ladder = sorted(
        wp.tol_ladder(quick), reverse=True
    )  # the flows' ladder: no new kernel to compile
    ref = wp.run_heyoka_batch(p, model, 1e-16, Y0)
    judge = float(np.max(np.abs(ref - wp.run_fast(p, model, "taylor", ladder[-1], (x0, pi0)))))

    def pick(run):
        for tol in ladder:
            y = run(tol)
            w = float(np.max(np.abs(y - ref)))
            if w <= tgt:
                return tol, w
        return ladder[-1], w

    tol_h, w_h = pick(lambda tol: wp.run_heyoka_batch(p, model, tol, Y0))
    tol_o, w_o = pick(lambda tol: wp.run_fast(p, model, "taylor", tol, (x0, pi0)))
    y_f = wp.run_fast(p, model, fixed_method, fixed_steps, (x0, pi0))
    w_f = float(np.max(np.abs(y_f - ref)))
    calls = [
        lambda: wp.run_heyoka_batch(p, model, tol_h, Y0),
        lambda: wp.run_fast(p, model, "taylor", tol_o, (x0, pi0)),
        lambda: wp.run_fast(p, model, fixed_method, fixed_steps, (x0, pi0)),
    ]
    tms = wp.time_points(calls, max_rounds=3, slow=30.0)
    _, W = wp.heyoka_batch_integrator(p, model, tol_h)
    labels = [
        f"heyoka taylor_adaptive_batch (width {W}, tol {tol_h:g})",
        f"tstarg taylor (adaptive, per-trajectory steps, local tol {tol_o:g}, {_ct_path()})",
        f"tstarg {fixed_method} ({fixed_steps} fixed steps, batched)",
    ]
    rows = []
    for lab, w, tm in zip(labels, (w_h, w_o, w_f), tms):
        rows.append(
            {
                "M": M,
                "label": lab,
                "worst": w,
                "time": tm["time"],
                "per_traj": tm["time"] / M,
                "ratio": tm["time"] / tms[0]["time"],
            }
        )
    return {
        "M": M,
        "target": tgt,
        "judge_disagreement": judge,
        "rows": rows,
        "note": (
            f"worst trajectory against heyoka at tol 1e-16 (its disagreement with tstarg taylor at {ladder[-1]:g} "
            f"is {judge:.1e}); ratio = time / heyoka's time, same run, CPU time, interleaved, best of 3"
        ),
    }


def _ct_path() -> str:
    return COMPILED_PATH


# ------------------------------------------------------------------ markdown
def _race_line(race) -> str:
    if not race:
        return "- scipy's right-hand side was not raced (Upsilon != 0: numpy body field only)"
    return (
        f"- scipy's right-hand side, raced on {race['setting']}: scalar {fmt_time(race['scalar'])}, "
        f"numpy body field {fmt_time(race['numpy'])} (time ratio numpy / scalar "
        f"{race['numpy'] / race['scalar']:.2f})"
    )


def _ladder_line(f: dict) -> str:
    """How the tstarg methods were driven: step counts for the fixed-step methods, tolerances for the
    adaptive ones (never a tolerance printed as a step count), and the skipped methods."""
    parts = []
    if f.get("ladder"):
        parts.append(
            f"fixed-step methods over step counts N on a geometric ladder from {f['ladder'][0]} to at "
            f"most {f['ladder'][1]} steps, growing by 2^min(1, 8/order) per rung"
        )
    if f.get("tol_ladder"):
        tl = f["tol_ladder"]
        parts.append(
            f"adaptive methods (tstarg `taylor`, heyoka) over the tolerances {tl[0]:.0e} to {tl[-1]:.0e}"
        )
    skipped = "; ".join(f"`{k}` ({v})" for k, v in f["skipped"].items()) or "none"
    return (
        "- tstarg methods: "
        + ("; ".join(parts) or "none")
        + f" (see the ladder stops below); skipped: {skipped}"
    )


def render_markdown(rep: dict) -> str:
    L = [
        "# tstarg bench: work-precision",
        "",
        f"- command: `{rep['command']}`",
        f"- references and error evaluations: {rep['parallel']}; {rep['timing']}",
        (
            f"- machine: {rep['environment']['platform']}, {rep['environment']['cpu_count']} cores, load average "
            f"{rep['loadavg_start'][0]:.2f} at start, {rep.get('loadavg_end', [math.nan])[0]:.2f} at the end "
            "(other processes share the cores: ratios from the same run are the comparable numbers)"
        ),
        f"- BLAS threads: {rep['environment']['blas_threads']}",
        f"- wall time of the run: {rep.get('seconds', math.nan):.0f} s",
        f"- compiled path: {rep.get('compiled_path', 'numpy')}; peer: {rep.get('heyoka', 'not included')}",
        (
            f"- compile times (apart from the run times): tstarg {rep['compile']['tstarg']}; heyoka JIT per "
            f"tolerance [s] {rep['compile']['heyoka']}"
            if "compile" in rep
            else "- compile times: not recorded"
        ),
        "",
    ]
    for key, r in rep.get("reused", {}).items():
        L.insert(
            -1,
            f"- section `{key}` reused from an earlier run (`--reuse`): command `{r['command']}`, commit "
            f"{r['git_commit']}, load average {((r.get('loadavg_start') or [math.nan])[0]):.2f} at its start",
        )
    if "protocol" in rep:
        L += _protocol_markdown(rep["protocol"])
    for name, f in rep["flows"].items():
        L += [
            f"## Flow: {f['title']}, t = {f['T']:g}",
            "",
            f"![work-precision {name}]({f['figure']})",
            "",
            f"- reference: {f['reference']['how']}",
            (
                "- error: worst component of |y(T) - y_ref(T)| over the body state "
                "(pi and Gamma with gravity, pi alone for the free top), one trajectory"
            ),
            f"- scipy `solve_ivp` gets the {f['scipy_rhs']}, rtol = atol; Radau: {f['radau_jacobian']}",
            _race_line(f.get("scipy_rhs_race")),
            _ladder_line(f),
            "",
            "### Time of the best tstarg method over scipy DOP853's at equal error",
            "",
            (
                "Times interpolated (log-log) on each method's own front (a method whose cheapest point already "
                "meets the error is charged that point's time, an upper bound); ratio < 1: tstarg is faster."
            ),
            "",
            (
                "| error | best tstarg method | its time | scipy DOP853 time | ratio tstarg / DOP853 | heyoka time | "
                "ratio tstarg / heyoka |"
            ),
            "|---|---|---|---|---|---|---|",
        ]
        for r in f["ratios"]:
            ratio = (
                f"{r['ratio_best_over_dop853']:.3g}"
                if r["ratio_best_over_dop853"] is not None
                else r["note"]
            )
            rh = r.get("ratio_best_over_heyoka")
            L.append(
                f"| {r['label']} | {r['best_tstarg'] or 'not reached'} | {fmt_time(r['t_best'])} | "
                f"{fmt_time(r['t_dop853']) if r['t_dop853'] else 'not reached'} | {ratio} | "
                f"{fmt_time(r['t_heyoka']) if r.get('t_heyoka') else '-'} | "
                f"{f'{rh:.3g}' if rh is not None else '-'} |"
            )
        L += [
            "",
            "### All points (Pareto table)",
            "",
            "| method | setting | error | CPU time | wall time | repeats | on front |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in sorted(f["points"], key=lambda r: (r["method"], r["time"])):
            st = (
                "its default accuracy"  # a contender whose flow takes neither steps= nor tol=
                if r["setting"] is None
                else {"steps": f"N = {r['setting']}", "tol": f"tol = {r['setting']:.0e}"}.get(
                    r["setting_name"], f"rtol = {r['setting']:.1e}"
                )
            )
            if "nfev" in r:
                st += f" ({r['nfev']} rhs evals)"
            L.append(
                f"| {r['method']} | {st} | {fmt_err(r['error'])} | {fmt_time(r['time'])} | "
                f"{fmt_time(r['wall'])} | {r['repeats']} | "
                f"{'**yes**' if r['on_front'] else ''} |"
            )
        L += ["", "Ladder stops: " + "; ".join(f"{k}: {v}" for k, v in f["stops"].items()), ""]
    if "brackets" in rep:
        b = rep["brackets"]
        L += [
            "## Brackets: the Poisson tensor (vier9, holonomic coordinates)",
            "",
            "".join(f"![brackets]({fig}) " for fig in b["figures"]),
            "",
            f"- error: {b['error']}",
            "- fast kernels: "
            + "; ".join(f"{c['algebra']}: {c.get('fast_path', '?')}" for c in b["cases"]),
            "- Theta = -xi.f (a coboundary, zeven3), Upsilon random antisymmetric, points with cond(Phi) < 1e3",
            "- the mpmath reference works at dps + 12 guard digits, so its errors lie far below 10^-dps",
            "",
            "| algebra | method | points | worst error | time per point | on front |",
            "|---|---|---|---|---|---|",
        ]
        for r in b["summary"]:
            L.append(
                f"| {r['algebra']} | {r['method']} | {r['points']} | {fmt_err(r['error'])} | "
                f"{fmt_time(r['time_per_point'])} | {'**yes**' if r.get('on_front') else ''} |"
            )
        L.append("")
    if "batch" in rep:
        b = rep["batch"]
        L += [
            "## Batch throughput (heavy top)",
            "",
            f"![batch]({b['figure']})",
            "",
            f"- {b['note']}",
            (
                f"- target error {b['target']:.0e}: tstarg `{b['method']}` with {b['steps']} steps, "
                f"scipy DOP853 with rtol = atol = {b['scipy_rtol']:.1e}"
            ),
            "",
            (
                "| trajectories | tstarg per trajectory | scipy DOP853 per trajectory (sample) | "
                "ratio tstarg / scipy | worst error (batch, vs 4x steps) | trajectory 0 vs mpmath | "
                "scipy worst (sample) |"
            ),
            "|---|---|---|---|---|---|---|",
        ]
        for r in b["rows"]:
            L.append(
                f"| {r['M']} | {fmt_time(r['ours_per_traj'])} | {fmt_time(r['scipy_per_traj'])} "
                f"({r['scipy_sample']}) | {r['ratio']:.3g} | {fmt_err(r['worst_vs_fine'])} | "
                f"{fmt_err(r['traj0_vs_reference'])} | {fmt_err(r['scipy_worst_vs_fine'])} |"
            )
        L.append("")
    if "impl" in rep:
        L += _impl_markdown(rep)
    if "batch_heyoka" in rep:
        b = rep["batch_heyoka"]
        L += [
            f"## Batch against heyoka ({b['M']} heavy-top trajectories, worst error target {b['target']:.0e})",
            "",
            f"- {b['note']}",
            "",
            "| contender | worst error | time per trajectory | ratio to heyoka |",
            "|---|---|---|---|",
        ]
        for r in b["rows"]:
            L.append(
                f"| {r['label']} | {fmt_err(r['worst'])} | {fmt_time(r['per_traj'])} | {r['ratio']:.3g} |"
            )
        L.append("")
    L += ["## Environment", "", "```", json.dumps(rep["environment"], indent=1), "```", ""]
    return "\n".join(L)


def _protocol_markdown(pr: dict) -> list[str]:
    """The protocol-flow section: the summary table (the ratios of interest), then per problem how it
    was built, its judge and heyoka's points."""
    L = [
        "## Protocol flow on every algebra against heyoka (full state)",
        "",
        f"- {pr['note']}",
        "- ratio = our CPU time / heyoka's at equal error: < 1 means the protocol flow is faster",
        (
            f"- kernel cache at the start of the section: {pr['kernel_cache']['files_at_start']} files in "
            f"{pr['kernel_cache']['dir']}"
            + (
                " (cold: each problem's first call below includes compiling its kernels)"
                if pr["kernel_cache"]["files_at_start"] == 0
                else " (first calls may load kernels from it instead of compiling)"
            )
            if "kernel_cache" in pr
            else "- kernel cache: not recorded"
        ),
        f"- the flows' time budget per call (TSTARG_TIME_BUDGET_S): {pr.get('time_budget_s', 'default')}",
        "",
        "| problem | algebra (n) | T | ours: time, error | heyoka at equal error: time, tol, mode, error "
        f"| ratio | batch of {pr['M']}: ours per trajectory, worst sampled error | heyoka batch per "
        "trajectory | batch ratio | our first call (CPU; compile or cache load) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in pr["problems"].items():
        o, b, hb = r["ours"], r["batch"], r["heyoka_best"]
        bb = b.get("heyoka_best")
        L.append(
            f"| {name} | {r['algebra']} ({r['n']}) | {r['T']:g} | {fmt_time(o['time'])}, "
            f"{fmt_err(o['error'])} | "
            + (
                f"{fmt_time(hb['time'])}, {hb['tol']:.2e}, {'compact' if hb['compact_mode'] else 'full'}, "
                f"{fmt_err(hb['error'])} | {r['ratio']:.3g}"
                + (" (heyoka's most accurate: it does not reach ours)" if r["note"] else "")
                if hb
                else f"{r['note']} | -"
            )
            + (
                f" | refused by the flow ({b['refused'][:120]}) | - | - |"
                if "refused" in b
                else f" | {fmt_time(b['ours']['per_traj'])}, {fmt_err(b['ours']['error'])} | "
                + (
                    f"{fmt_time(bb['time'] / b['M'])} (tol {bb['tol']:.2e}, width {bb['width']}) | "
                    f"{b['ratio']:.3g}"
                    + (" (heyoka's most accurate: it does not reach ours)" if b.get("note") else "")
                    + " |"
                    if bb
                    else "not reached | - |"
                )
            )
            + f" {o.get('first_call_cpu', math.nan):.2f} s |"
        )
    L.append("")
    for name, r in pr["problems"].items():
        ref = r["reference"]
        L += [f"### {name}: {r['title']}, T = {r['T']:g}", ""]
        L += [f"- {h}" for h in r["how"]]
        L.append(f"- judge: {ref['how']} ({ref['seconds']:.1f} s)")
        if r["note"]:
            L.append(f"- {r['note']}")
        if r["batch"].get("note"):
            L.append(f"- batch: {r['batch']['note']}")
        if "min_abs_delta" in ref:
            L.append(
                f"- away from the degenerate set: along the trajectory (401 points) min |Delta| = "
                f"{ref['min_abs_delta']:.3g}, max cond(Phi) = {ref['max_cond_phi']:.3g}"
            )
        L.append(
            f"- ours: {r['ours']['label']}; first call (compilation or cache load, and one run) "
            f"{r['ours']['first_call']:.2f} s wall, {r['ours'].get('first_call_cpu', math.nan):.2f} s CPU"
            + (
                f"; batch refused: {r['batch']['refused']}"
                if "refused" in r["batch"]
                else f"; batch first call {r['batch']['ours']['first_call']:.2f} s"
                + (f" ({r['batch']['ours']['note']})" if r["batch"]["ours"].get("note") else "")
            )
        )
        L.append(
            "- heyoka's grid (compact mode, error per tolerance): "
            + ", ".join(f"{g['tol']:.1e}: {fmt_err(g['error'])}" for g in r["heyoka_grid"])
        )
        L += ["", "| heyoka tol | mode | error | CPU time | repeats |", "|---|---|---|---|---|"]
        for h in r["heyoka"]:
            L.append(
                f"| {h['tol']:.2e} | {'compact' if h['compact_mode'] else 'full'} | "
                f"{fmt_err(h['error'])} | {fmt_time(h['time'])} | {h['repeats']} |"
            )
        L.append("")
    L += [
        "heyoka JIT compile time per integrator [s] (apart from the run times): "
        + ", ".join(f"{k}: {v:.2f}" for k, v in pr["compile_heyoka"].items()),
        "",
    ]
    return L


# ------------------------------------------------------------------ a third-party contender
def _load_contender(args):
    """The ``--impl``/``--cmd`` contender, or None; a clear ``ValueError`` naming a bad spec."""
    if getattr(args, "impl", None) is None and getattr(args, "cmd", None) is None:
        return None
    if args.cmd is not None:
        what = f"--cmd {args.cmd!r}"
        timeout = check_timeout(args.timeout, "--timeout")
        try:
            obj = CommandImplementation(args.cmd, timeout=timeout, startup_timeout=timeout)
        except (ProgramFailure, OSError) as exc:
            raise ValueError(f"{what}: the program cannot be used: {exc}") from None
        provided = [m for m in ("flow", "poisson_tensor") if m not in obj._missing]
    else:
        what = f"--impl {args.impl!r}"
        try:
            obj = (
                resolve(args.impl, what="--impl") if ":" in args.impl else import_module(args.impl)
            )
        except ImportError as exc:
            raise ValueError(f"{what}: cannot import it: {exc}") from None
        provided = [m for m in ("flow", "poisson_tensor") if provides(obj, m)]
    if not provided:
        if isinstance(obj, CommandImplementation):
            obj.close()
        raise ValueError(
            f"{what} provides neither flow nor poisson_tensor (the protocol methods tstarg bench "
            "times: docs/design.md, the implementation protocol)"
        )
    return _Contender(obj, what, provided)


class _Contender:
    """A third-party implementation of the protocol on the work-precision diagrams.

    Flows: its ``flow`` on each problem's full state ``(x0, pi0)`` to ``T`` over the settings
    :func:`reports._workprecision.impl_flow_setting` finds (``steps=``, ``tol=``, or one point),
    judged by the same error function against the same reference as ours (``Gamma`` from its ``x``),
    timed in the same :func:`time_points` call as ours, scipy and heyoka (interleaved, CPU time,
    best of repeats). Brackets: its ``poisson_tensor`` one call per point (and on the whole batch
    when it declares ``batched``), judged like ours at every point of the same cases."""

    def __init__(self, obj, what: str, provided: list[str]):
        self.obj, self.what, self.provided = obj, what, provided
        self.name = str(getattr(obj, "name", None) or what)
        self.label = f"impl {self.name}"
        self.ladders: dict = {}

    def close(self) -> None:
        close = getattr(self.obj, "close", None)
        if isinstance(self.obj, CommandImplementation) and callable(close):
            close()

    def describe(self) -> dict:
        return {
            "name": self.name,
            "spec": self.what,
            "version": str(getattr(self.obj, "version", "")),
            "provides": self.provided,
            "flow_setting": wp.impl_flow_setting(self.obj) if "flow" in self.provided else None,
            "batched": bool(getattr(self.obj, "batched", False)),
            "note": (
                "its flow integrates the protocol's full state (x, pi) from (x0, pi0); ours, scipy "
                "and heyoka integrate the body system (pi, Gamma); its error is judged on pi and "
                "Gamma = Ad(exp(x))^T gamma against the same reference"
            ),
        }

    def flow_rows(self, name, quick, ref, S) -> list:
        """``(row, callable)`` per point of its ladder on problem ``name`` (errors judged here)."""
        if "flow" not in self.provided:
            return []
        p = wp.flow_problem(name, quick)
        lad = wp.impl_ladder(self.obj, p, ref["values"], S["floor"], quick)
        self.ladders[name] = lad
        print(
            f"  {name}: {self.label}: {len(lad['points'])} points ({lad['setting_name']}); "
            f"stop: {lad['stop']}",
            flush=True,
        )
        return [
            (
                {
                    "method": self.label,
                    "family": "impl",
                    "setting_name": lad["setting_name"],
                    **pt,
                },
                wp.impl_flow_call(self.obj, p, lad["setting_name"], pt["setting"]),
            )
            for pt in lad["points"]
        ]

    def flow_ratios(self, name: str, flow: dict) -> None:
        """Add its time at each error target and the ratios ``impl / ours`` (the best tstarg method
        there) and ``impl / heyoka`` to the problem's ratio rows."""
        pts = [r for r in flow["points"] if r["method"] == self.label]
        if not pts:
            return
        for r in flow["ratios"]:
            t = wp.impl_time_at(pts, r["target"])
            ok = math.isfinite(t)
            r["t_impl"] = t if ok else None
            r["ratio_impl_over_ours"] = t / r["t_best"] if ok and r.get("t_best") else None
            r["ratio_impl_over_heyoka"] = t / r["t_heyoka"] if ok and r.get("t_heyoka") else None
        flow["impl_stop"] = self.ladders.get(name, {}).get("stop")

    def bracket_rows(self, quick, S, opts):
        """The ``extra`` hook of :func:`_brackets`: its tensors at every point (judged in parallel
        by :func:`reports._workprecision.bracket_error_of_task`) and its timed calls."""
        if "poisson_tensor" not in self.provided:
            return None
        obj = self.obj

        def extra(cases):
            items, rows, calls = [], [], []
            for ci, case in enumerate(cases):
                f = np.array(catalogue(case["algebra"]).f, dtype=float)
                for j in range(len(case["x"])):
                    try:
                        P = np.asarray(
                            obj.poisson_tensor(
                                f, case["theta"], case["upsilon"], case["x"][j], case["pi"][j]
                            ),
                            dtype=float,
                        ).tolist()
                    except Exception as exc:  # noqa: BLE001 - third-party code: judged, not trusted
                        P = f"{type(exc).__name__}: {exc}"[:200]
                    items.append((ci, quick, j, P, S["bracket_high"]))
            errs = map_tasks(wp.bracket_error_of_task, items, **opts)
            k = 0
            for ci, case in enumerate(cases):
                m = len(case["x"])
                err = max(errs[k : k + m])
                k += m
                for suffix, pts, call in wp.impl_bracket_calls(
                    obj, case, bool(getattr(obj, "batched", False))
                ):
                    rows.append(
                        {
                            "algebra": case["algebra"],
                            "method": f"{self.label}, {suffix}",
                            "dps": None,
                            "route": "impl",
                            "error": err,
                            "points": pts,
                            "family": "impl",
                        }
                    )
                    calls.append(call)
            return rows, calls

        return extra

    def bracket_ratios(self, br: dict) -> None:
        """Ratios of its time per point over ours, per algebra: one call per point against ours one
        call per point, its batch against our batch."""
        out = []
        for alg in dict.fromkeys(r["algebra"] for r in br["summary"]):
            rows = {r["method"]: r for r in br["summary"] if r["algebra"] == alg}
            for suffix, ours in (
                ("one call per point", "fast, one call per point"),
                ("batch", "fast batch"),
            ):
                mine = rows.get(f"{self.label}, {suffix}")
                if mine is None or ours not in rows:
                    continue
                out.append(
                    {
                        "algebra": alg,
                        "impl": mine["method"],
                        "ours": ours,
                        "impl_error": mine["error"],
                        "ours_error": rows[ours]["error"],
                        "impl_time_per_point": mine["time_per_point"],
                        "ours_time_per_point": rows[ours]["time_per_point"],
                        "ratio_impl_over_ours": mine["time_per_point"]
                        / rows[ours]["time_per_point"],
                    }
                )
        br["impl_ratios"] = out


def _impl_markdown(rep: dict) -> list[str]:
    """The report's section on the ``--impl``/``--cmd`` contender."""
    im = rep["impl"]
    L = [
        f"## Third-party implementation: {im['name']}",
        "",
        f"- given as {im['spec']} (version {im['version'] or '-'}); provides {', '.join(im['provides'])}; "
        f"flow driven by: {im['flow_setting'] or '-'} "
        "(`steps=`: a step ladder; `tol=`: a tolerance ladder; default: one point)",
        f"- {im['note']}",
        "- times from the same interleaved runs as ours (CPU time, best of repeats); ratio > 1: "
        "the implementation is slower; a point more accurate than a target is charged at that "
        "target (an upper bound: with one point, every coarser target gets the same time)",
        "",
    ]
    for name, f in rep["flows"].items():
        pts = [r for r in f["points"] if r.get("family") == "impl"]
        if not pts:
            continue
        L += [
            f"### Flow: {f['title']}, t = {f['T']:g}",
            "",
            "| error | impl time | best tstarg method | its time | ratio impl / ours | heyoka time | "
            "ratio impl / heyoka |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in f["ratios"]:
            ro, rh = r.get("ratio_impl_over_ours"), r.get("ratio_impl_over_heyoka")
            L.append(
                f"| {r['label']} | {fmt_time(r.get('t_impl')) if r.get('t_impl') else 'not reached'} | "
                f"{r['best_tstarg'] or 'not reached'} | {fmt_time(r['t_best'])} | "
                f"{f'{ro:.3g}' if ro is not None else '-'} | "
                f"{fmt_time(r['t_heyoka']) if r.get('t_heyoka') else '-'} | "
                f"{f'{rh:.3g}' if rh is not None else '-'} |"
            )
        L += ["", "| setting | error | CPU time | on front |", "|---|---|---|---|"]
        for r in sorted(pts, key=lambda r: r["time"]):
            L.append(
                f"| {r['setting_name']} {'' if r['setting'] is None else r['setting']} | "
                f"{fmt_err(r['error'])} | {fmt_time(r['time'])} | {'**yes**' if r['on_front'] else ''} |"
            )
        L.append("")
    br = rep.get("brackets", {}).get("impl_ratios")
    if br:
        L += [
            "### Brackets (Poisson tensor, time per point)",
            "",
            "| algebra | impl | its worst error | its time | ours | our worst error | our time | "
            "ratio impl / ours |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for r in br:
            L.append(
                f"| {r['algebra']} | {r['impl']} | {fmt_err(r['impl_error'])} | "
                f"{fmt_time(r['impl_time_per_point'])} | {r['ours']} | {fmt_err(r['ours_error'])} | "
                f"{fmt_time(r['ours_time_per_point'])} | {r['ratio_impl_over_ours']:.3g} |"
            )
        L.append("")
    return L
