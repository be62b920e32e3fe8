"""Regression reports: compare a ``tstarg verify`` run with a baseline run.

Two kinds of regression are flagged, check by check (rows matched by name):

**accuracy**: digits lost since the baseline,
``lost = max(d_base - d_new, log10(r_new / r_base))`` with ``d`` the check's minimum
correct digits and ``r`` its worst error/tolerance ratio (a check that was exact and no
longer is has lost ``inf`` digits). A loss above ``digits_slack`` (default 2) is a
regression. Digits are compared only between runs drawing the same examples (same profile,
examples per check and seed); runs drawing different examples are compared for
information and the accuracy verdict does not fail on them (a minimum over a different
sample is a different statistic).

**speed**: every row carrying ``extra["speedup"]`` (a ratio ``t_baseline / t_ours`` timed in
one run, :mod:`reports.speed_checks`; never bare seconds) regresses when it slowed down by the
factor or more, ``speedup_base / speedup_new >= speed_factor`` (default factor 2, so a 2x
slowdown of any row fails; the noise of ratios measured alternately on a loaded 2-core machine
stays well inside it).

**a stale baseline**: when every speed row of the new run is at least ``speed_factor`` times
faster than in the baseline, a slowdown back to the baseline's level would pass unnoticed. The
comparison says so (``stale``, with the command that renews the baseline); it is a warning, not
a failure.

Also flagged: a check that passed in the baseline and fails now. A check missing from
the new run (e.g. ``--provider`` ran a subset) is listed, not failed.

:func:`compare` returns a plain dict (JSON-ready); :func:`render_markdown` and
:func:`plot` present it; :func:`regression_checks` turns it into two
:class:`~properties.core_checks.CheckResult` rows for ``tstarg verify``.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from tstarg.properties.runner import CheckResult
from tstarg.refimpl.scenes import MAX_NESTING, nesting_depth, read_regular_file

from ._atomic import save_figure

__all__ = [
    "BASELINE",
    "DIGITS_SLACK",
    "SPEED_FACTOR",
    "RENEW",
    "load_report",
    "read_json_file",
    "compare",
    "render_markdown",
    "plot",
    "regression_checks",
]

BASELINE = Path(__file__).resolve().parent / "baseline" / "report.json"
"""The committed baseline: ``tstarg verify --profile ci --seed 0`` on the reference machine."""
DIGITS_SLACK = 2.0
SPEED_FACTOR = 2.0
RENEW = "tstarg verify --profile ci --seed 0 --write-baseline"
"""The command that renews the committed baseline (run it on a quiet machine, then commit
``reports/baseline/report.json``)."""


MAX_REPORT_BYTES = 64 * 2**20
"""Reader budget: a report, baseline or certificate is at most 64 MiB."""


def read_json_file(path, *, what: str = "file", max_bytes: int = MAX_REPORT_BYTES):
    """A JSON document read only from a regular file within ``max_bytes`` (FIFOs, devices,
    folders, empty, binary, malformed or too deeply nested files: one ``ValueError`` each)."""
    data = read_regular_file(path, what=what, max_bytes=max_bytes, empty_ok=True)
    if not data.strip():
        raise ValueError(f"{what} {path}: not valid JSON (the file is empty)")
    try:
        obj = json.loads(data.decode("utf-8"))
    except UnicodeDecodeError:
        raise ValueError(f"{what} {path}: not UTF-8 text (a binary file?)") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what} {path}: not valid JSON ({exc})") from None
    except RecursionError:
        raise ValueError(f"{what} {path}: nested too deeply") from None
    if nesting_depth(obj) > MAX_NESTING:
        raise ValueError(f"{what} {path}: nested too deeply (at most {MAX_NESTING} levels)")
    return obj


def load_report(path) -> dict:
    """A ``report.json`` (or a run folder holding one) as a dict; clear errors for anything else."""
    p = Path(path)
    if p.is_dir():
        p = p / "report.json"
        if not p.exists():
            raise FileNotFoundError(
                f"no report at {path} (expected a report.json or a folder holding one)"
            )
    rep = read_json_file(p, what="report")
    if not isinstance(rep, dict) or not isinstance(rep.get("checks"), list):
        raise ValueError(f"{p}: not a tstarg verify report (no 'checks' list)")
    for i, c in enumerate(rep["checks"]):
        _validate_row(c, f"{p}: checks[{i}]")
    names = [c["name"] for c in rep["checks"]]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"{p}: check name(s) {dup[:5]} appear more than once")
    if "passed" in rep and not isinstance(rep["passed"], bool):
        raise ValueError(f"{p}: 'passed' must be true or false, got {rep['passed']!r:.40}")
    rep["_path"] = str(p)
    return rep


_NONFINITE = {"inf": math.inf, "-inf": -math.inf, "Infinity": math.inf, "-Infinity": -math.inf}


def _strict_num(v, where: str, *, allow_nan: bool) -> float | None:
    """A report number: null, a JSON number, or the strings "inf"/"-inf" (:meth:`CheckResult.to_json`);
    NaN only where ``allow_nan``. Anything else (``"lots"``, ``true``) is a clear error."""
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        raise ValueError(f"{where} must be a number or null, got {v!r:.40}")
    if isinstance(v, str):
        if v in _NONFINITE:
            return _NONFINITE[v]
        if v.lower() == "nan":
            x = math.nan
        else:
            raise ValueError(f"{where} must be a number or null, got the string {v!r:.40}")
    else:
        x = float(v)
    if math.isnan(x) and not allow_nan:
        raise ValueError(f"{where} is NaN in a check marked passed: the report is corrupted")
    return x


def _validate_row(c, where: str) -> None:
    """One check row of a report: ``name`` (non-empty string), ``passed`` (true/false), numbers
    ``min_digits``, ``worst_ratio`` and ``extra.speedup`` as :func:`_strict_num` accepts."""
    if not isinstance(c, dict):
        raise ValueError(f"{where} must be an object, got {type(c).__name__}")
    if not isinstance(c.get("name"), str) or not c["name"]:
        raise ValueError(f"{where}: 'name' must be a non-empty string, got {c.get('name')!r:.40}")
    where = f"{where} ({c['name'][:60]})"
    if not isinstance(c.get("passed"), bool):
        raise ValueError(f"{where}: 'passed' must be true or false, got {c.get('passed')!r:.40}")
    nan_ok = not c["passed"]
    for key in ("min_digits", "worst_ratio"):
        _strict_num(c.get(key), f"{where}: {key!r}", allow_nan=nan_ok)
    extra = c.get("extra")
    if extra is not None and not isinstance(extra, dict):
        raise ValueError(f"{where}: 'extra' must be an object, got {type(extra).__name__}")
    if extra and "speedup" in extra:
        sp = _strict_num(extra["speedup"], f"{where}: extra.speedup", allow_nan=nan_ok)
        if sp is not None and c["passed"] and not sp > 0:
            raise ValueError(f"{where}: extra.speedup must be > 0 in a passed check, got {sp!r}")


def _num(v):
    """JSON values to floats (rows validated by :func:`_validate_row`): None stays None, "inf" strings
    to inf; NaN (allowed only in failed rows) becomes None, i.e. unknown."""
    if v is None or isinstance(v, bool):
        return None
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(x) else x


def _digits_lost(b: dict, n: dict) -> float | None:
    losses = []
    db, dn = _num(b.get("min_digits")), _num(n.get("min_digits"))
    if db is not None and dn is not None:
        if math.isinf(db) and math.isinf(dn):
            losses.append(0.0)
        elif math.isinf(db):
            losses.append(math.inf)
        elif not math.isinf(dn):
            losses.append(db - dn)
        else:
            losses.append(-math.inf)
    rb, rn = _num(b.get("worst_ratio")), _num(n.get("worst_ratio"))
    if (
        rb is not None
        and rn is not None
        and rb > 0
        and rn > 0
        and math.isfinite(rb)
        and math.isfinite(rn)
    ):
        losses.append(math.log10(rn / rb))
    elif rb is not None and rn is not None and math.isfinite(rb) and math.isinf(rn):
        losses.append(math.inf)
    return max(losses) if losses else None


def _sampling(rep: dict) -> tuple:
    return rep.get("profile"), rep.get("max_examples"), rep.get("seed")


def compare(
    base: dict, new: dict, *, digits_slack: float = DIGITS_SLACK, speed_factor: float = SPEED_FACTOR
) -> dict:
    """Row-by-row comparison of two verify reports (dicts from :func:`load_report`)."""
    if not (digits_slack >= 0 and math.isfinite(digits_slack)):
        raise ValueError(f"digits_slack must be a finite number >= 0, got {digits_slack}")
    if not (speed_factor >= 1 and math.isfinite(speed_factor)):
        raise ValueError(f"speed_factor must be a finite number >= 1, got {speed_factor}")
    same = _sampling(base) == _sampling(new)
    # the regression rows of either run are verdicts about some other pair of runs: not compared
    bmap = {c["name"]: c for c in base["checks"] if not c["name"].startswith("regression.")}
    nmap = {c["name"]: c for c in new["checks"] if not c["name"].startswith("regression.")}
    rows = []
    for name in list(bmap) + [k for k in nmap if k not in bmap]:
        b, n = bmap.get(name), nmap.get(name)
        row = {
            "name": name,
            "status": [],
            "digits_base": None,
            "digits_new": None,
            "digits_lost": None,
            "speedup_base": None,
            "speedup_new": None,
            "speed_factor": None,
        }
        if n is None:
            row["status"].append("missing in new run")
            rows.append(row)
            continue
        if b is None:
            row["status"].append("new check")
            row["digits_new"] = _num(n.get("min_digits"))
            row["speedup_new"] = _num((n.get("extra") or {}).get("speedup"))
            rows.append(row)
            continue
        row["digits_base"], row["digits_new"] = _num(b.get("min_digits")), _num(n.get("min_digits"))
        lost = _digits_lost(b, n)
        row["digits_lost"] = lost
        if b.get("passed") and not n.get("passed"):
            row["status"].append("verdict regression (PASS -> FAIL)")
        if lost is not None and lost > digits_slack:
            row["status"].append(
                "accuracy regression" if same else "accuracy change (different samples)"
            )
        sb, sn = (
            _num((b.get("extra") or {}).get("speedup")),
            _num((n.get("extra") or {}).get("speedup")),
        )
        if sb is not None and sn is not None and sb > 0 and sn > 0:
            row["speedup_base"], row["speedup_new"] = sb, sn
            row["speed_factor"] = sb / sn
            if sb / sn >= speed_factor:
                row["status"].append("speed regression")
        rows.append(row)
    acc = [
        r["name"]
        for r in rows
        if "accuracy regression" in r["status"]
        or "verdict regression (PASS -> FAIL)" in r["status"]
    ]
    spd = [r["name"] for r in rows if "speed regression" in r["status"]]
    timed = [r for r in rows if r["speed_factor"] is not None]
    stale = bool(timed) and all(r["speed_factor"] <= 1 / speed_factor for r in timed)
    faster = ", ".join("{} {:.3g}x".format(r["name"], 1 / r["speed_factor"]) for r in timed)
    return {
        "base": base.get("_path", "base"),
        "new": new.get("_path", "new"),
        "same_sampling": same,
        "sampling_base": list(_sampling(base)),
        "sampling_new": list(_sampling(new)),
        "digits_slack": digits_slack,
        "speed_factor": speed_factor,
        "rows": rows,
        "accuracy_regressions": acc,
        "speed_regressions": spd,
        "regressed": bool(acc or spd),
        "stale": stale,
        "stale_note": (
            f"the baseline is stale: every speed row is at least {speed_factor:g}x faster than in "
            f"the baseline ({faster}), "
            f"so a slowdown back to the baseline's level would pass; renew it with `{RENEW}` on a "
            "quiet machine and commit reports/baseline/report.json"
            if stale
            else ""
        ),
    }


def _f(v, fmt="{:.1f}") -> str:
    if v is None:
        return "-"
    if isinstance(v, float) and math.isinf(v):
        return "exact" if v > 0 else "-inf"
    return fmt.format(v)


def render_markdown(cmp: dict, figure: str | None = None) -> str:
    """The comparison as Markdown, readable on its own."""
    out = [
        "# tstarg: comparison of two verification runs",
        "",
        f"- base: `{cmp['base']}` (profile, examples per check, seed = {cmp['sampling_base']})",
        f"- new: `{cmp['new']}` (profile, examples per check, seed = {cmp['sampling_new']})",
        f"- accuracy regression: more than {cmp['digits_slack']:g} digits lost "
        f"(max of the drop in minimum digits and log10 of the growth of the worst error/tolerance ratio)"
        + (
            ""
            if cmp["same_sampling"]
            else "; **the runs drew different examples, so digit changes are "
            "shown for information and do not fail**"
        ),
        f"- speed regression: a speed-up (ratio to a baseline computation timed in the same run) "
        f"fell by more than {cmp['speed_factor']:g}x",
        f"- verdict: **{'REGRESSED' if cmp['regressed'] else 'no regression'}**"
        + (
            f" (accuracy: {', '.join(cmp['accuracy_regressions']) or 'none'}; "
            f"speed: {', '.join(cmp['speed_regressions']) or 'none'})"
            if cmp["regressed"]
            else ""
        ),
        *([f"- **{cmp['stale_note']}**"] if cmp.get("stale") else []),
        "",
    ]
    if figure:
        out += [f"![digits and speed-ups, base vs new]({figure})", ""]
    out += [
        "| check | digits base | digits new | digits lost | speed-up base | speed-up new | slowdown | status |",
        "|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in cmp["rows"]:
        out.append(
            f"| {r['name']} | {_f(r['digits_base'])} | {_f(r['digits_new'])} | {_f(r['digits_lost'])} | "
            f"{_f(r['speedup_base'], '{:.3g}')} | {_f(r['speedup_new'], '{:.3g}')} | "
            f"{_f(r['speed_factor'], '{:.2f}x')} | {'; '.join(r['status']) or 'ok'} |"
        )
    return "\n".join(out) + "\n"


def plot(cmp: dict, path) -> Path | None:
    """Two panels: minimum digits per check (base vs new) and speed-ups (base vs new), PNG.

    A figure is an illustration of the comparison, never a reason to lose it: if drawing fails
    the error is printed and ``None`` returned (the report and ``compare.md`` are still written).
    """
    try:
        return _plot(cmp, path)
    except Exception as exc:  # noqa: BLE001 - see the docstring
        print(f"comparison figure not drawn ({type(exc).__name__}: {exc})", file=sys.stderr)
        return None


def _plot(cmp: dict, path) -> Path:
    import matplotlib  # local: heavy, and only for the comparison figure

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in cmp["rows"] if r["digits_base"] is not None or r["digits_new"] is not None]
    spd = [r for r in cmp["rows"] if r["speedup_base"] is not None or r["speedup_new"] is not None]

    def cap(v):  # exact (inf) digits drawn at 70, missing as nan
        return float("nan") if v is None else (70.0 if math.isinf(v) else v)

    # constrained layout keeps the one legend (below both panels, off the bars) and every label
    # inside the canvas; tests/test_figures.py checks both
    fig, axes = plt.subplots(
        1,
        2,
        figsize=(13, max(3.5, 0.28 * len(rows) + 2.2)),
        gridspec_kw={"width_ratios": [3, 2]},
        layout="constrained",
    )
    ax = axes[0]
    y = list(range(len(rows)))
    ax.barh(
        [v - 0.2 for v in y],
        [cap(r["digits_base"]) for r in rows],
        height=0.4,
        label="base",
        color="0.7",
    )
    ax.barh(
        [v + 0.2 for v in y],
        [cap(r["digits_new"]) for r in rows],
        height=0.4,
        label="new",
        color=["tab:red" if ("accuracy regression" in r["status"]) else "tab:blue" for r in rows],
    )
    ax.set_yticks(y, [r["name"][:42] for r in rows], fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("minimum correct digits (exact drawn at 70)")
    ax = axes[1]
    y = list(range(len(spd)))
    ax.barh(
        [v - 0.2 for v in y],
        [r["speedup_base"] or float("nan") for r in spd],
        height=0.4,
        color="0.7",
        label="base",
    )
    ax.barh(
        [v + 0.2 for v in y],
        [r["speedup_new"] or float("nan") for r in spd],
        height=0.4,
        label="new",
        color=["tab:red" if "speed regression" in r["status"] else "tab:green" for r in spd],
    )
    ax.set_yticks(y, [r["name"] for r in spd], fontsize=8)
    ax.invert_yaxis()
    positive = [
        v
        for r in spd
        for v in (r["speedup_base"], r["speedup_new"])
        if v is not None and math.isfinite(v) and v > 0
    ]
    if positive:
        ax.set_xscale("log")
    else:  # no speed rows (e.g. a run of core_checks only): a log axis cannot be drawn
        ax.text(
            0.5,
            0.5,
            "no speed-up rows in these runs",
            ha="center",
            va="center",
            transform=ax.transAxes,
        )
    ax.set_xlabel("speed-up vs baseline computation (same run)")
    from matplotlib.patches import Patch  # local: matplotlib, as above

    fig.legend(
        handles=[
            Patch(color="0.7", label="base"),
            Patch(color="tab:blue", label="new: digits"),
            Patch(color="tab:green", label="new: speed-up"),
            Patch(color="tab:red", label="new: regression"),
        ],
        loc="outside lower center",  # matplotlib >= 3.7 with constrained layout
        ncol=4,
        fontsize=8,
    )
    fig.suptitle("base (grey) vs new; red = regression", fontsize=10)
    path = Path(path)
    try:
        save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)
    return path


def regression_checks(cmp: dict):
    """Two verify rows: ``regression.accuracy`` and ``regression.speed``. Their worst ratio is
    (digits lost / slack) and (slowdown / factor): above 1 fails, like every other row."""

    acc_rows = [r for r in cmp["rows"] if r["digits_lost"] is not None]
    spd_rows = [r for r in cmp["rows"] if r["speed_factor"] is not None]
    lost = max((r["digits_lost"] for r in acc_rows), default=0.0)
    slack = cmp["digits_slack"] or 1e-300
    acc_ratio = max(0.0, lost) / slack if cmp["same_sampling"] else 0.0
    if cmp["accuracy_regressions"] and not acc_ratio > 1:
        acc_ratio = math.inf  # a PASS -> FAIL verdict change
    slow = max((r["speed_factor"] for r in spd_rows), default=0.0)
    note = "" if cmp["same_sampling"] else " (different samples: digits shown, not enforced)"
    acc = CheckResult(
        name="regression.accuracy",
        equations="(meta)",
        examples=len(acc_rows),
        worst_ratio=acc_ratio,
        passed=not cmp["accuracy_regressions"],
        detail=(
            f"accuracy regressions against {cmp['base']}: {', '.join(cmp['accuracy_regressions'])}"
            if cmp["accuracy_regressions"]
            else f"max digits lost {lost:.2f} (slack {cmp['digits_slack']:g}){note}"
        ),
        extra={
            "baseline": cmp["base"],
            "digits_slack": cmp["digits_slack"],
            "same_sampling": cmp["same_sampling"],
        },
    )
    spd = CheckResult(
        name="regression.speed",
        equations="(meta)",
        examples=len(spd_rows),
        worst_ratio=slow / cmp["speed_factor"],
        passed=not cmp["speed_regressions"],
        detail=(
            f"speed regressions against {cmp['base']}: {', '.join(cmp['speed_regressions'])}"
            if cmp["speed_regressions"]
            else f"worst slowdown {slow:.2f}x (a slowdown of {cmp['speed_factor']:g}x or more fails)"
        ),
        extra={"baseline": cmp["base"], "speed_factor": cmp["speed_factor"]},
    )
    return [acc, spd]
