"""The worker of ``tstarg run`` (:mod:`reports.cmd_run` parses the arguments and calls
:func:`main`): plan the scene, integrate it, write npz, CSV and the plot."""

from __future__ import annotations

import csv
import io
import sys
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from tstarg.refimpl.flows import load_scene, plan, run_scene
from tstarg.refimpl.scenes import plot_trajectory

from . import _progress
from ._atomic import claim_output, safe_name, save_figure, write_bytes, write_text


def _plot(out: dict, path: Path, title: str) -> None:
    """``trajectory.png``: :func:`refimpl.scenes.plot_trajectory`, saved atomically."""
    import matplotlib  # heavy, and only for the PNG (--no-plot skips it)

    matplotlib.use("Agg")  # a file, never a window
    import matplotlib.pyplot as plt

    fig = plot_trajectory(out, title)
    try:
        save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)


def main(args) -> int:
    threadpool_limits(1)

    with _progress.Progress(
        "run", total=1, quiet=_progress.is_quiet(args), unit="samples"
    ) as display:
        display.phase("planning (a pilot run fixes the step count of a fixed-step method)")
        try:
            scene = load_scene(args.scene)
            the_plan = plan(scene)
        except (ValueError, OSError) as exc:
            display.close()
            print(f"tstarg run: {exc}", file=sys.stderr)
            return 2
        print(f"scene: {scene.name}")
        print(the_plan.describe())
        step = f"integrating {Path(args.scene).stem}"
        display.start(step, total=scene.samples)
        # run_scene reports sample k of 0..total (the first is the initial state)
        out = run_scene(scene, the_plan, progress=lambda k, total: display.update(k + 1, total + 1))
        display.done(step, f"{scene.samples} samples")
        print(f"path: {out.pop('path')}")  # what ran, as the integrator reports it
        return _write(args, scene, out, display)


def _write(args, scene, out, display) -> int:
    """The npz, CSV and PNG of a run, the drift lines; ``display`` shows the file being written."""

    # the default folder is named from the scene file, sanitised: a file named "...toml" must not
    # resolve to reports/ itself (issue 15); a concurrent run on the same folder gets its own
    folder = (
        Path(args.out)
        if args.out
        else Path("reports") / "runs" / safe_name(Path(args.scene).stem, default="scene")
    )
    folder = claim_output(folder)
    display.phase(f"writing {folder}")
    arrays = {k: np.asarray(v) for k, v in out.items() if not k.startswith("note")}
    buf = io.BytesIO()
    np.savez(buf, **{safe_name(k.replace(" ", "_")): v for k, v in arrays.items()})
    write_bytes(folder / "trajectory.npz", buf.getvalue())
    fh = io.StringIO(newline="")
    w = csv.writer(fh)
    cols, header = [], ["t"]
    for k, v in arrays.items():
        if k == "times":
            continue
        v0 = v[:, 0] if v.ndim >= 2 else v
        if v0.ndim == 1:
            cols.append(v0)
            header.append(k.replace(" ", "_"))
        else:
            for a in range(v0.shape[1]):
                cols.append(v0[:, a])
                header.append(f"{k}_{a}")
    w.writerow(header)
    for i, t in enumerate(out["times"]):
        w.writerow([repr(float(t))] + [repr(float(c[i])) for c in cols])
    write_text(folder / "trajectory.csv", fh.getvalue())
    for k, v in out.items():
        if k.startswith("note"):
            print(f"note: {v}")
    for k in arrays:
        if k == "energy" or k.startswith("casimir") or k == "momentum_map":
            d = np.abs(arrays[k] - arrays[k][0])
            print(f"drift of {k} (worst trajectory): {np.nanmax(d):.3g}")
    if not args.no_plot:
        display.phase("drawing trajectory.png")
        _plot(out, folder / "trajectory.png", scene.name)
    print(
        f"wrote {folder}/trajectory.npz, trajectory.csv"
        + ("" if args.no_plot else ", trajectory.png")
    )
    return 0
