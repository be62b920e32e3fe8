"""The worker of ``tstarg stress`` (:mod:`reports.cmd_stress` parses the arguments and calls
:func:`main`): run the sweeps (:mod:`reports._stress` holds the tasks), write the report and figures."""

from __future__ import annotations

import json
import math
import platform
import subprocess
import sys
import time
from pathlib import Path

import mpmath
import numpy as np
import scipy
import sympy
from threadpoolctl import threadpool_limits

from . import _progress
from ._atomic import claim_output, save_figure, write_text
from ._parallel import describe, map_tasks, parallel_options
from ._stress import (
    D64,
    brouwer_items,
    build_sweeps,
    load_implementation,
    point_items,
    summarize_brouwer,
    summarize_points,
    task,
)

MARKERS = {
    "ok": ("o", "tab:green"),
    "escalated": ("s", "tab:blue"),
    "flagged": ("^", "tab:orange"),
    "SILENT FAILURE": ("X", "tab:red"),
}


def _task_name(item: dict) -> str:
    """A stress task as the progress display names it."""
    if item.get("task") == "brouwer":
        return f"brouwer {item['tag']} chunk {item['chunk']} ({item['trajectories']} trajectories)"
    return f"{item['sweep']} point {item['index']}"


# ----------------------------------------------------------------- running
def run(
    *,
    quick: bool,
    tol: float,
    escalate: bool,
    judge_dps: int,
    implementation: str,
    sweeps: list | None,
    brouwer_time: float | None,
    brouwer_trajectories: int | None,
    workers=None,
    scheduler=None,
    display=None,
) -> dict:
    """The whole stress run as a report dict (no files written). ``display``: an open
    :class:`reports._progress.Progress`, told of each task as its result arrives."""

    if not (isinstance(tol, float) and math.isfinite(tol) and tol > 0):
        raise ValueError(f"--tol must be a finite number > 0, got {tol!r}")
    if not isinstance(judge_dps, int) or judge_dps < 30:
        raise ValueError(f"--judge-dps must be an int >= 30, got {judge_dps!r}")
    load_implementation(implementation)  # a clear error before any task runs
    sw = build_sweeps(quick=quick, only=sweeps)
    items = []
    want_brouwer = not sweeps or "brouwer" in sweeps
    if want_brouwer:
        items += brouwer_items(quick, brouwer_time, brouwer_trajectories)  # longest tasks first
    items += point_items(sw, tol, escalate, judge_dps, implementation)
    t0 = time.perf_counter()
    on_result = None
    if display is not None:
        display.add_total(len(items))
        display.phase(f"running {len(items)} tasks")
        on_result = display.callback(
            lambda i, r: _task_name(items[i]),
            lambda i, r: r.get("outcome", "done") if isinstance(r, dict) else "done",
        )
    results = map_tasks(task, items, workers=workers, scheduler=scheduler, on_result=on_result)
    wall = time.perf_counter() - t0
    rows = [r for it, r in zip(items, results) if it["task"] == "point"]
    brouwer = (
        summarize_brouwer([r for it, r in zip(items, results) if it["task"] == "brouwer"])
        if want_brouwer
        else None
    )
    return {
        "command": "tstarg stress " + " ".join(sys.argv[2:])
        if sys.argv[1:2] == ["stress"]
        else "tstarg stress",
        "settings": {
            "quick": quick,
            "tol": tol,
            "tol_kind": "relative: tol * max(1, max_ij |ref_ij|)",
            "escalate": escalate,
            "judge_dps": [judge_dps, judge_dps + 20],
            "implementation": implementation,
            "float64_digits": _stress_d64(),
            "seeds": {
                "brouwer": "numpy default_rng(1000 + chunk), 32 trajectories per chunk",
                "sweeps": "fixed in reports/_stress.py: default_rng(0) (degenerate, from seed 0 "
                "on), 11 (momenta), 12 (upsilon); exact rational bases",
            },
        },
        "environment": _environment(),
        "wall_seconds": wall,
        "sweeps": [
            {
                "name": s.name,
                "title": s.title,
                "kind": s.kind,
                "algebra": s.algebra,
                "param": s.param,
                "description": s.description,
                "rows": [r for r in rows if r["sweep"] == s.name],
            }
            for s in sw
        ],
        "brouwer": brouwer,
        "summary": summarize_points(rows),
    }


def _stress_d64() -> float:
    return D64


def _environment() -> dict:
    import matplotlib  # heavy (only its version is wanted here); the plots import it themselves

    try:
        here = Path(__file__).resolve().parent
        commit = (
            subprocess.run(
                ["git", "rev-parse", "HEAD"],
                capture_output=True,
                text=True,
                timeout=10,
                check=False,
                cwd=here,
            ).stdout.strip()
            or None
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
            cwd=here,
        ).stdout.strip()
        if commit and dirty:
            commit += " + uncommitted changes"
    except (OSError, subprocess.SubprocessError):
        commit = None
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "machine": platform.machine(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "mpmath": mpmath.__version__,
        "sympy": sympy.__version__,
        "matplotlib": matplotlib.__version__,
        "git_commit": commit,
        "blas_threads": 1,
    }


# ------------------------------------------------------------------ output
def _clean(v):
    """JSON-safe: non-finite floats become strings ("inf", "nan")."""
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    return v


def _fmt(v, spec=".2e") -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        if math.isnan(v):
            return "NaN"
        if math.isinf(v):
            return "inf"
        return format(v, spec)
    return str(v)


def _md(text: str) -> str:
    """Text safe inside a Markdown table cell."""
    return str(text).replace("|", "\\|")


def _plot_sweep(sweep: dict, path: Path, tol: float, d64: float) -> None:
    import matplotlib  # heavy, and only for the figures

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = sweep["rows"]
    finite = [r["param"] for r in rows if math.isfinite(r["param"])]
    edge = (max(finite) * 30) if finite else 1.0
    xs = [r["param"] if math.isfinite(r["param"]) else edge for r in rows]
    fig, ax = plt.subplots(figsize=(9.5, 4.6), constrained_layout=True)
    ax.plot(
        xs,
        [r["lost_predicted"] for r in rows],
        "-",
        color="0.4",
        lw=1.2,
        label="predicted (error_bound)",
    )
    ax.plot(
        xs,
        [r["lost_final"] for r in rows],
        ":",
        color="tab:purple",
        lw=1,
        label="returned value (after escalation)",
    )
    for outcome, (m, c) in MARKERS.items():
        sel = [(x, r["lost_fast"]) for x, r in zip(xs, rows) if r["outcome"] == outcome]
        if sel:
            ax.scatter(*zip(*sel), marker=m, color=c, s=46, zorder=3, label=f"fast: {outcome}")
    ax.axhline(
        d64 + math.log10(tol),
        color="tab:red",
        ls="--",
        lw=0.8,
        label=f"tolerance {tol:g} ({d64 + math.log10(tol):.1f} digits may be lost)",
    )
    ax.axhline(d64, color="k", ls=":", lw=0.6)
    if any(not math.isfinite(r["param"]) for r in rows):
        ax.annotate(
            "Delta = 0\nexactly",
            (edge, d64),
            textcoords="offset points",
            xytext=(-10, -30),
            fontsize=8,
        )
    ax.set_xscale("log")
    ax.set_ylim(-0.5, d64 + 1)
    ax.set_xlabel(sweep["param"])
    ax.set_ylabel("digits lost (of 15.95)")
    ax.set_title(f"{sweep['name']}: {sweep['title']}", fontsize=10)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _plot_brouwer(b: dict, path: Path) -> None:
    import matplotlib  # heavy, and only for the figures

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, rms = np.asarray(b["t"]), np.asarray(b["rms"])
    fig, ax = plt.subplots(figsize=(10, 4.6), constrained_layout=True)
    ax.loglog(
        t,
        rms,
        "o",
        ms=4,
        label=f"RMS energy error, {b['trajectories']} trajectories (DOP853, h = {b['h']:g})",
    )
    sel = t >= b["fit_from_t"]
    ax.loglog(
        t[sel],
        b["coefficient"] * t[sel] ** b["exponent"],
        "-",
        color="tab:orange",
        label=f"fit: t^{b['exponent']:.3f}",
    )
    # Brouwer's law through the fitted curve's value at the geometric middle of the fit range
    tm = float(np.sqrt(t[sel][0] * t[sel][-1]))
    cm = b["coefficient"] * tm ** b["exponent"] / math.sqrt(tm)
    ax.loglog(t, cm * np.sqrt(t), "--", color="k", lw=0.8, label="Brouwer's law: c sqrt(t)")
    ax.set_xlabel("t")
    ax.set_ylabel("RMS |H(t) - H(0)| (exact evaluation)")
    ax.set_title("Long integration: round-off in the energy against Brouwer's law", fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def write(report: dict, out: Path, display=None) -> None:
    """``report.json``, ``report.md`` and one PNG per sweep (+ ``brouwer.png``) under ``out``
    (``display``: a :class:`reports._progress.Progress` shown the figure being drawn)."""
    out.mkdir(parents=True, exist_ok=True)
    st = report["settings"]
    d64, tol = st["float64_digits"], st["tol"]
    figures = [sw for sw in report["sweeps"] if sw["rows"]]
    for k, sw in enumerate(figures):
        if display is not None:
            display.phase(f"drawing {sw['name']}.png ({k + 1}/{len(figures)})")
        _plot_sweep(sw, out / f"{sw['name']}.png", tol, d64)
    if report["brouwer"]:
        if display is not None:
            display.phase("drawing brouwer.png")
        _plot_brouwer(report["brouwer"], out / "brouwer.png")
    if display is not None:
        display.phase("writing report.json and report.md")
    write_text(out / "report.json", json.dumps(_clean(report), indent=1))
    write_text(out / "report.md", render_markdown(report))


def render_markdown(report: dict) -> str:
    st, sm = report["settings"], report["summary"]
    d64, tol = st["float64_digits"], st["tol"]
    env = report["environment"]
    verdict = (
        "PASS: zero silent failures, every error bound held"
        if not (
            sm["silent_failures"]
            or sm["bound_violations_fast"]
            or sm["bound_violations_final"]
            or sm["judge_problems"]
        )
        else "FAIL"
    )
    L = [
        "# tstarg stress: numerical stability of the fast implementation",
        "",
        (
            f"`{report['command']}` on {env['platform']} (Python {env['python']}, numpy {env['numpy']}, "
            f"mpmath {env['mpmath']}; commit {env['git_commit'] or 'unknown'}); BLAS pinned to 1 thread; "
            f"wall time {report['wall_seconds']:.1f} s."
        ),
        "",
        (
            f"**{verdict}.** {sm['points']} points: "
            + ", ".join(f"{v} {k}" for k, v in sm["outcomes"].items())
            + f"; error-bound violations: {sm['bound_violations_fast']} (fast), {sm['bound_violations_final']} "
            f"(returned values, after escalation); judge disagreements: {sm['judge_problems']}."
        ),
        "",
        "## How to read this report",
        "",
        (
            f"* Implementation under stress: `{st['implementation']}`; requested tolerance `tol = {tol:g}`, relative: "
            f"a point is within it when `max_ij |value - ref| <= tol * max(1, max_ij |ref|)`. Mode: "
            + (
                "**escalate** (points whose error bound exceeds the tolerance are recomputed by the mpmath reference, "
                "`refimpl.escalate`)."
                if st["escalate"]
                else "**flag only** (`--no-escalate`)."
            )
        ),
        (
            f"* The judge is `refimpl.reference.Reference` at {st['judge_dps'][0]} and {st['judge_dps'][1]} digits on "
            "the same float64 inputs (taken as exact binary numbers); its two precisions must agree to 25 digits."
        ),
        (
            f"* **digits lost** = {d64:.2f} (what float64 can give, `-log10(eps/2)`) minus the digits obtained, "
            "`-log10(err / max(1, max|ref|))`; **predicted** is the same quantity for the fast `error_bound` "
            "(`C_P n eps max(cond_phi, cond_data) frame_cond max|P|`, refimpl/fast.py). A NaN answer (the fast "
            "implementation's degenerate flag) loses all digits."
        ),
        (
            f"* The dashed red line is the tolerance: points above it ({d64 + math.log10(tol):.1f} digits lost) must "
            "be escalated or flagged; a point above it that is neither is a **SILENT FAILURE**."
        ),
        (
            "* **bound held**: `err <= error_bound` for the fast value (where the bound is finite) and for the value "
            "returned (after escalation)."
        ),
        "* `cond2(Phi)` and `|Delta|` are computed by mpmath (singular values, determinant) for the float64 inputs.",
        "",
    ]
    bad = [
        r
        for sw in report["sweeps"]
        for r in sw["rows"]
        if r["outcome"] == "SILENT FAILURE" or not r["bound_held_fast"] or not r["bound_held_final"]
    ]
    if bad:
        L += [
            "## Findings: silent failures and error-bound violations",
            "",
            "| sweep | point | fast err | error_bound | allowed (tol x scale) | outcome | bound held (fast/returned) |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in bad:
            L.append(
                f"| {r['sweep']} | {_md(r['label'])} | {_fmt(r['err_fast'])} | {_fmt(r['bound_fast'])} | "
                f"{_fmt(r['allowed'])} | {r['outcome']} | {'yes' if r['bound_held_fast'] else 'NO'}/"
                f"{'yes' if r['bound_held_final'] else 'NO'} |"
            )
        L.append("")
    for sw in report["sweeps"]:
        rows = sw["rows"]
        if not rows:
            continue
        L += [
            f"## {sw['name']}: {sw['title']}",
            "",
            f"{_md(sw['description'])} ({sw['kind']}; algebra {sw['algebra']}).",
            "",
            f"![{sw['name']}]({sw['name']}.png)",
            "",
            (
                f"| {_md(sw['param'])} | point | cond2(Phi) | \\|Delta\\| | fast err | error_bound | lost | predicted | "
                "outcome | escalation dps | returned: err | bound held (fast/returned) |"
            ),
            "|---|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in rows:
            held = (
                ("yes" if r["bound_held_fast"] else "**NO**")
                + "/"
                + ("yes" if r["bound_held_final"] else "**NO**")
            )
            out = r["outcome"] if r["outcome"] != "SILENT FAILURE" else "**SILENT FAILURE**"
            L.append(
                f"| {_fmt(r['param'], '.3g')} | {_md(r['label'])} | {_fmt(r['cond_phi_true'], '.2e')} | "
                f"{_fmt(r['delta_abs'], '.2e')} | {_fmt(r['err_fast'])} | {_fmt(r['bound_fast'])} | "
                f"{r['lost_fast']:.1f} | {r['lost_predicted']:.1f} | {out} | {r['escalation_dps'] or '-'} | "
                f"{_fmt(r['err_final'])} | {held} |"
            )
        notes = sorted({r["reason"] for r in rows if r["outcome"] == "flagged" and r["reason"]})
        if notes:
            L += ["", "Flagged because: " + "; ".join(notes) + "."]
        L.append("")
    b = report["brouwer"]
    if b:
        tc = b["truncation_check"]
        L += [
            "## brouwer: long integration against Brouwer's law",
            "",
            (
                f"Free rigid body on su(2) (I = diag(1, 2, 3), Upsilon = 0), {b['trajectories']} trajectories with "
                f"random unit momenta, DOP853 (`refimpl.flows.integrate_fast`, body system) at the fixed step "
                f"h = {b['h']:g} to t = {b['T']:g}. The energy of each computed state is evaluated exactly (mpmath, "
                "40 digits) and compared with the exact initial energy, so the curve is the integrator's own error. "
                "Brouwer's law: unbiased rounding errors accumulate as a random walk, `RMS ~ c sqrt(t)`."
            ),
            "",
            "![brouwer](brouwer.png)",
            "",
            "| quantity | value |",
            "|---|---|",
            f"| fitted exponent p (RMS ~ c t^p, t >= {b['fit_from_t']:g}) | **{b['exponent']:.3f}** |",
            "| Brouwer's law | 0.5 |",
            f"| consistent (0.35 <= p <= 0.65) | {'yes' if b['consistent_with_brouwer'] else '**no**'} |",
            f"| RMS energy error at t = {b['T']:g} | {b['rms'][-1]:.3e} |",
            (
                f"| truncation check: RMS(2h) / RMS(h) at t = {b['T']:g} | {tc['ratio_2h_over_h']:.3f} "
                f"(round-off predicts {tc['round_off_predicts']:.3f}, truncation {tc['truncation_predicts']:.0f}) |"
            ),
            f"| integration time (all chunks) | {b['seconds']:.1f} s |",
            "",
        ]
    return "\n".join(L) + "\n"


def main(args) -> int:
    threadpool_limits(1)

    try:
        par = parallel_options(args)
        sweeps = [s.strip() for s in args.sweeps.split(",") if s.strip()] if args.sweeps else None
    except ValueError as exc:
        print(f"tstarg stress: {exc}", file=sys.stderr)
        return 2
    print(
        f"tstarg stress{' --quick' if args.quick else ''}: tol {args.tol:g} (relative), "
        f"{'escalate' if not args.no_escalate else 'flag only'}, implementation {args.implementation}; "
        f"{describe(**par)}; BLAS pinned to 1 thread",
        flush=True,
    )
    with _progress.Progress("stress", quiet=_progress.is_quiet(args)) as display:
        display.phase("building the sweeps")
        try:
            report = run(
                quick=args.quick,
                tol=float(args.tol),
                escalate=not args.no_escalate,
                judge_dps=args.judge_dps,
                implementation=args.implementation,
                sweeps=sweeps,
                brouwer_time=args.brouwer_time,
                brouwer_trajectories=args.brouwer_trajectories,
                display=display,
                **par,
            )
        except (ValueError, ImportError, AttributeError) as exc:
            display.close()
            print(f"tstarg stress: {exc}", file=sys.stderr)
            return 2
        out = claim_output(Path(args.out))  # a concurrent run gets its own folder and says so
        write(report, out, display)
    sm = report["summary"]
    for sw in report["sweeps"]:
        counts = {}
        for r in sw["rows"]:
            counts[r["outcome"]] = counts.get(r["outcome"], 0) + 1
        worst = max((r["lost_fast"] for r in sw["rows"]), default=0.0)
        print(
            f"  {sw['name']:<24} {len(sw['rows']):>3} points  "
            + ", ".join(f"{v} {k}" for k, v in counts.items())
            + f"  (max digits lost by fast: {worst:.1f})"
        )
    b = report["brouwer"]
    if b:
        print(
            f"  brouwer: RMS energy error ~ t^{b['exponent']:.3f} (Brouwer's law: t^0.5), "
            f"{b['trajectories']} trajectories to t = {b['T']:g}"
        )
    print(
        f"silent failures: {sm['silent_failures']}; bound violations: {sm['bound_violations_fast']} (fast), "
        f"{sm['bound_violations_final']} (returned values, after escalation); judge disagreements: {sm['judge_problems']}"
    )
    print(f"wrote {out}/report.json, report.md and PNGs ({report['wall_seconds']:.1f} s)")
    bad = (
        sm["silent_failures"]
        or sm["bound_violations_fast"]
        or sm["bound_violations_final"]
        or sm["judge_problems"]
    )
    return 1 if bad else 0
