"""Every figure kind the commands write is drawn legibly: each title, label, tick label and legend
lies inside the canvas (nothing cut off), and no legend covers data (a line, a marker, a bar).

The figures are drawn by the commands' own plotting functions from small inputs; the check looks
at the drawn artists (their extents in display coordinates after layout), not at pixels. Each
rule has a negative control: a figure with a title wider than the canvas and one with a legend on
its line are caught.
"""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

SLACK = 1.0  # pixels: rounding of the extents


def _inside(bb, fb) -> bool:
    return (
        bb.x0 >= fb.x0 - SLACK
        and bb.y0 >= fb.y0 - SLACK
        and bb.x1 <= fb.x1 + SLACK
        and bb.y1 <= fb.y1 + SLACK
    )


def _densify(xy: np.ndarray, k: int = 16) -> np.ndarray:
    """Points along each segment of a polyline (display coordinates), so a legend sitting on a
    segment between two vertices is seen."""
    if len(xy) < 2:
        return xy
    s = np.linspace(0.0, 1.0, k, endpoint=False)[None, :, None]
    a, b = xy[:-1, None, :], xy[1:, None, :]
    return np.concatenate([(a + s * (b - a)).reshape(-1, 2), xy[-1:]])


def _data_in(ax, renderer):
    """Display-coordinate points of the data of ``ax`` (lines densified, markers) and the boxes of
    its bars, restricted to the axes' own area."""
    area = ax.get_window_extent(renderer)
    pts = []
    for line in ax.get_lines():
        if not line.get_visible():
            continue
        xy = line.get_transform().transform(np.asarray(line.get_xydata(), dtype=float))
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        pts.append(_densify(xy) if line.get_linestyle() not in ("None", "", " ") else xy)
    for coll in ax.collections:
        off = np.asarray(coll.get_offsets(), dtype=float)
        if off.size:
            xy = coll.get_offset_transform().transform(off)
            pts.append(xy[np.all(np.isfinite(xy), axis=1)])
    pts = np.concatenate(pts) if pts else np.empty((0, 2))
    keep = (
        (pts[:, 0] >= area.x0)
        & (pts[:, 0] <= area.x1)
        & (pts[:, 1] >= area.y0)
        & (pts[:, 1] <= area.y1)
    )
    boxes = [p.get_window_extent(renderer) for p in ax.patches if p.get_visible()]
    return pts[keep], [b for b in boxes if b.width > 0 and b.height > 0]


def problems(fig: Figure) -> list[str]:
    """What is wrong with a drawn figure (empty: nothing)."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    fb = fig.bbox
    out = []
    legends = list(fig.legends)
    for t in fig.texts:  # the suptitle and figure-level texts
        if t.get_visible() and t.get_text().strip() and not _inside(t.get_window_extent(r), fb):
            out.append(f"text cut off by the canvas: {t.get_text()[:60]!r}")
    for k, ax in enumerate(fig.axes):
        # everything the axes draws: title, axis labels, the tick labels shown, texts, its legend
        if not _inside(ax.get_tightbbox(r), fb):
            parts = [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
            out.append(
                f"axes {k} ({' / '.join(p for p in parts if p)[:60]!r}) cut off by the canvas"
            )
        if ax.get_legend() is not None:
            legends.append(ax.get_legend())
    for leg in legends:
        lb = leg.get_window_extent(r)
        if not _inside(lb, fb):
            out.append("legend cut off by the canvas")
        for ax in fig.axes:
            pts, boxes = _data_in(ax, r)
            inside = (
                (pts[:, 0] > lb.x0)
                & (pts[:, 0] < lb.x1)
                & (pts[:, 1] > lb.y0)
                & (pts[:, 1] < lb.y1)
            )
            if inside.any():
                out.append(f"legend covers {int(inside.sum())} data points of an axes")
            if any(lb.overlaps(b) for b in boxes):
                out.append("legend covers a bar")
    return out


@pytest.fixture
def drawn(monkeypatch):
    """Every figure saved while the fixture is active (whatever route saves it)."""
    figs: list[Figure] = []
    original = Figure.savefig
    close = plt.close

    def savefig(self, *args, **kwargs):
        figs.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    monkeypatch.setattr(plt, "close", lambda *a, **k: None)  # keep them for the check
    yield figs
    for f in figs:
        close(f)


# ---------------------------------------------------------------- negative controls
def test_checker_catches_a_cut_title_and_a_legend_on_data():
    fig, ax = plt.subplots(figsize=(4, 3), layout="constrained")
    t = np.linspace(0, 1, 50)
    ax.plot(t, t, label="the diagonal")
    ax.legend(loc="center")  # on the line
    ax.set_title(
        "a title much, much wider than a four-inch canvas can ever hold, cut off at both ends"
    )
    got = problems(fig)
    assert any("cut off" in p for p in got) and any("legend covers" in p for p in got), got
    fig2, ax2 = plt.subplots(figsize=(4, 3), layout="constrained")
    ax2.bar([0, 1, 2], [3, 3, 3], label="bars")
    ax2.legend(loc="center")
    assert any("bar" in p for p in problems(fig2))
    fig3, ax3 = plt.subplots(figsize=(6, 3), layout="constrained")
    ax3.plot(t, t, label="the diagonal")
    ax3.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax3.set_title("short")
    assert problems(fig3) == []
    for f in (fig, fig2, fig3):
        plt.close(f)


# ---------------------------------------------------------------- the figure kinds
LONG = "se(2) (solvable, e0 rotation, e1 e2 translations) with the non-trivial cocycle Theta_12 (not in B^2)"


def test_trajectory_figure_of_tstarg_run(drawn, tmp_path):
    from tstarg.reports import _run as cmd_run

    T, N, n = 41, 2, 3
    t = np.linspace(0, 20, T)
    pi = np.stack([np.sin(t + k) for k in range(n)], axis=-1)[:, None, :].repeat(N, axis=1)
    out = {
        "times": t,
        "pi": pi,
        "energy": 1 + 1e-16 * np.cos(7 * t)[:, None].repeat(N, axis=1),
        "momentum_map": 1
        + 1e-15 * np.sin(3 * t)[:, None, None].repeat(N, axis=1).repeat(n, axis=2),
    }
    cmd_run._plot(out, tmp_path / "trajectory.png", LONG)
    assert len(drawn) == 1
    assert problems(drawn[0]) == []


def test_compare_figure_of_verify(drawn, tmp_path):
    from tstarg.reports import regression

    def row(name, d0, d1, s0=None, s1=None, status=()):
        return {
            "name": name,
            "digits_base": d0,
            "digits_new": d1,
            "speedup_base": s0,
            "speedup_new": s1,
            "status": list(status),
        }

    rows = [row(f"check_{k}[with a long parameter list]", 10 + k, 11 + k) for k in range(12)]
    rows[3] = row("exact_check", math.inf, math.inf)
    rows += [
        row("speed.poisson[su2]", None, None, 147.0, 877.0),
        row("speed.poisson[su3]", None, None, 7.5, 3.0, ["speed regression"]),
        row("speed.flow[heavy_top]", None, None, 51.6, 174.0),
    ]
    assert regression._plot({"rows": rows}, tmp_path / "compare.png") is not None
    assert len(drawn) == 1
    assert problems(drawn[0]) == []


def test_stress_figures(drawn, tmp_path):
    from tstarg.reports import _stress_run as cmd_stress

    rows = []
    for k, p in enumerate([1e1, 1e2, 1e3, 1e5, 1e7, 1e9, 1e11, 1e13, 1e15, math.inf]):
        lost = min(15.95, 0.7 + 1.1 * k)
        rows.append(
            {
                "param": p,
                "lost_predicted": min(16.2, 4 + k * 1.2),
                "lost_final": 0.1,
                "lost_fast": lost,
                "outcome": ["ok", "escalated", "flagged"][k % 3],
            }
        )
    sweep = {
        "name": "degenerate-su2",
        "title": "su(2), Upsilon = tau.eps: toward C1 = 0",
        "param": "1/C1",
        "rows": rows,
    }
    cmd_stress._plot_sweep(sweep, tmp_path / "sweep.png", 1e-10, 15.95)
    t = np.geomspace(0.5, 1e4, 40)
    b = {
        "t": list(t),
        "rms": list(1e-16 * np.sqrt(t)),
        "trajectories": 128,
        "h": 0.05,
        "fit_from_t": 6.0,
        "exponent": 0.49,
        "coefficient": 1e-16,
        "T": 1e4,
    }
    try:
        cmd_stress._plot_brouwer(b, tmp_path / "brouwer.png")
    except KeyError as exc:  # the brouwer summary carries more fields than drawn here
        pytest.fail(f"the test's Brouwer summary lacks {exc}: update it")
    assert len(drawn) == 2
    for fig in drawn:
        assert problems(fig) == []
