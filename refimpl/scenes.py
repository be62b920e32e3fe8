"""Scenes: one problem in a TOML file, and the planner that picks the cheapest computation.

A scene (read with ``tomllib``) has these keys; anything else is rejected by name.

``name`` (str), ``algebra`` (catalogue name) or ``f`` ((n, n, n) list);
``theta`` ((n, n)) or ``xi`` ((n,), Theta = -xi.f, zeven3); ``upsilon``
((n, n)) or ``tau`` ((3,), su(2) only, Upsilon^mn = tau_l eps_lmn);
``inertia`` ((n, n)) or ``inertia_diagonal`` ((n,)); optional table
``[potential]`` with ``L`` and ``gamma`` ((n,) each, gravity twee15);
``x0``, ``pi0`` ((n,) or (N, n)); ``t_end`` (> 0); ``samples`` (>= 2);
``tol`` (> 0); optional ``method`` (a key of ``METHODS``);
``outputs`` (subset of ``pi``, ``x``, ``Gamma``, ``energy``, ``casimirs``,
``momentum_map``).

The planner (:func:`plan`) states each choice and what it skipped:

* no configuration integration unless ``x`` or ``momentum_map`` is asked for:
  the body system is closed when ``V = 0`` (Euler) and, with gravity, the
  reduced Euler-Poisson system ``(pi, Gamma)`` replaces ``g``;
* no Phi solve when ``Upsilon = 0`` (``Phi = 1``);
* the method: Gauss-Legendre order 6 when ``Upsilon != 0`` (symplectic for
  omega_L), else the compiled adaptive Taylor method (numba present; body
  systems and the su(2) full state: order and steps from ``tol`` per
  trajectory, two runs keep every trajectory within ``tol``), else the Lie-Poisson splitting for su(2) with diagonal inertia at
  loose tolerances (``tol >= 1e-6``), else fixed-step DOP853 (as generated
  scalar code for a single trajectory of a body system); the step count
  comes from a pilot run on ``[0, min(t_end, 1)]`` with doubling until the
  Richardson estimate meets ``tol * h_pilot / t_end``, so that the global
  error over ``t_end`` stays near ``tol`` when errors grow linearly.
"""

from __future__ import annotations

import os
import stat
import textwrap
import tomllib
from dataclasses import dataclass, field

import numpy as np

from . import _compiled_taylor
from ._catalogue import catalogue
from ._fast_kernels import FastCore
from ._flow_checks import check_time
from ._flow_compiled import supports_full
from ._validate import MAX_FLOW_TIME, MIN_FLOW_TOL, as_float_array, check_flow_rates, check_inertia
from .flows._fast import NumpyModel, fast_trajectory, integrate_fast
from .flows.base import check_tolerance
from .flows.invariants import casimirs, energy, momentum_map
from .flows.registry import METHODS

MAX_SAMPLES = 10**6
"""Loader budget: at most this many output samples per trajectory."""
MAX_POINTS = 10**4
"""Loader budget: at most this many trajectories in one scene."""
MAX_SAMPLE_VALUES = 10**8
"""Loader budget: samples x points x n numbers per output (800 MB of float64)."""
MAX_NAME = 200
"""Longest scene name (output names are sanitised from it by the commands)."""

__all__ = ["Scene", "Plan", "load_scene", "parse_scene", "plan", "run_scene", "OUTPUTS"]

OUTPUTS = ("pi", "x", "Gamma", "energy", "casimirs", "momentum_map")
KEYS = {
    "name",
    "algebra",
    "f",
    "theta",
    "xi",
    "upsilon",
    "tau",
    "inertia",
    "inertia_diagonal",
    "potential",
    "x0",
    "pi0",
    "t_end",
    "samples",
    "tol",
    "method",
    "outputs",
}


@dataclass
class Scene:
    name: str
    f: np.ndarray
    algebra: object
    theta: np.ndarray
    upsilon: np.ndarray
    inertia: np.ndarray
    potential: dict | None
    x0: np.ndarray
    pi0: np.ndarray
    t_end: float
    samples: int
    tol: float
    method: str | None
    outputs: tuple


@dataclass
class Plan:
    system: str
    method: str
    steps_per_sample: int
    phi_solve: bool
    skipped: list = field(default_factory=list)
    reasons: list = field(default_factory=list)

    def describe(self) -> str:
        lines = [
            f"system: {self.system}",
            f"method: {self.method} "
            + (
                f"({self.steps_per_sample} step{'s' if self.steps_per_sample != 1 else ''} per sample)"
                if self.steps_per_sample
                else "(adaptive: steps from the tolerance, per trajectory)"
            ),
        ]
        lines += [f"chose: {r}" for r in self.reasons]
        lines += [f"skipped: {s}" for s in self.skipped]
        return "\n".join(lines)


def _arr(d, key, shape, *, allow_batch=False):
    try:
        a = as_float_array(d[key], f"scene key {key!r}")
    except ValueError as exc:
        raise ValueError(f"{exc} (expected a numeric array of shape {shape})") from None
    ok = a.shape == shape or (allow_batch and a.ndim == 2 and a.shape[1:] == shape)
    if not ok:
        exp = f"{shape} or (N, {shape[0]})" if allow_batch else f"{shape}"
        raise ValueError(f"scene key {key!r} must have shape {exp}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"scene key {key!r} contains NaN or infinity")
    return a


def parse_scene(d: dict) -> Scene:
    """Validate a scene dictionary (from TOML); every error names the key and the expected shape."""
    unknown = sorted(set(d) - KEYS)
    if unknown:
        raise ValueError(f"unknown scene key(s) {unknown}; allowed: {sorted(KEYS)}")
    if ("algebra" in d) == ("f" in d):
        raise ValueError(
            "a scene needs exactly one of 'algebra' (catalogue name) or 'f' (structure constants)"
        )
    if "algebra" in d:
        if not isinstance(d["algebra"], str):
            raise ValueError(
                f"scene key 'algebra' must be a catalogue name (a string), got {d['algebra']!r:.60}"
            )
        try:
            alg = catalogue(d["algebra"])
        except (KeyError, ValueError) as exc:
            raise ValueError(f"scene key 'algebra': {exc}") from None
        f = alg.f
    else:
        f = as_float_array(d["f"], "scene key 'f'")
        if f.ndim != 3 or len(set(f.shape)) != 1:
            raise ValueError(f"scene key 'f' must have shape (n, n, n), got {f.shape}")
        alg = None
    n = f.shape[0]
    if "theta" in d and "xi" in d:
        raise ValueError("give 'theta' or 'xi', not both")
    theta = (
        _arr(d, "theta", (n, n))
        if "theta" in d
        else (-np.einsum("k,kab->ab", _arr(d, "xi", (n,)), f) if "xi" in d else np.zeros((n, n)))
    )
    if "upsilon" in d and "tau" in d:
        raise ValueError("give 'upsilon' or 'tau', not both")
    if "tau" in d:
        if n != 3:
            raise ValueError(
                "scene key 'tau' is for 3-dimensional algebras (su(2)); give 'upsilon' of shape (n, n)"
            )
        eps = np.zeros((3, 3, 3))
        for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
            eps[a, b, c], eps[a, c, b] = 1.0, -1.0
        upsilon = np.einsum("l,lmn->mn", _arr(d, "tau", (3,)), eps)
    else:
        upsilon = _arr(d, "upsilon", (n, n)) if "upsilon" in d else np.zeros((n, n))
    if ("inertia" in d) == ("inertia_diagonal" in d):
        raise ValueError(
            "a scene needs exactly one of 'inertia' ((n, n)) or 'inertia_diagonal' ((n,))"
        )
    inertia = (
        _arr(d, "inertia", (n, n)) if "inertia" in d else np.diag(_arr(d, "inertia_diagonal", (n,)))
    )
    pot = None
    if "potential" in d:
        p = d["potential"]
        if not isinstance(p, dict):
            raise ValueError("scene key 'potential' must be a table with 'L' and 'gamma'")
        extra = sorted(set(p) - {"L", "gamma"})
        if extra:
            raise ValueError(
                f"unknown key(s) {extra} in scene table 'potential' (allowed: L, gamma)"
            )
        for k in ("L", "gamma"):
            if k not in p:
                raise ValueError(f"scene table 'potential' needs {k!r} of shape ({n},)")
        pot = {"kind": "gravity", "L": _arr(p, "L", (n,)), "gamma": _arr(p, "gamma", (n,))}
    for k in ("x0", "pi0", "t_end"):
        if k not in d:
            raise ValueError(f"scene key {k!r} is required")
    x0 = _arr(d, "x0", (n,), allow_batch=True)
    pi0 = _arr(d, "pi0", (n,), allow_batch=True)
    x0, pi0 = np.atleast_2d(x0), np.atleast_2d(pi0)
    if x0.shape[0] != pi0.shape[0]:
        if x0.shape[0] == 1:
            x0 = np.repeat(x0, pi0.shape[0], axis=0)
        else:
            raise ValueError(
                f"scene keys 'x0' and 'pi0' must have the same number of points, "
                f"got {x0.shape} and {pi0.shape}"
            )

    if isinstance(d["t_end"], (bool, str)):
        raise ValueError(f"scene key 't_end' must be a number > 0, got {d['t_end']!r}")
    t_end = check_time(d["t_end"], "t_end")
    if t_end == 0:
        raise ValueError("scene key 't_end' must be > 0")
    if t_end > MAX_FLOW_TIME:
        raise ValueError(
            f"scene key 't_end' = {t_end:g} exceeds the budget t_end <= {MAX_FLOW_TIME:g}"
        )
    samples = d.get("samples", 101)
    if isinstance(samples, bool) or not isinstance(samples, int) or not 2 <= samples <= MAX_SAMPLES:
        raise ValueError(
            f"scene key 'samples' must be an int in [2, {MAX_SAMPLES}], got {samples!r}"
        )
    if x0.shape[0] > MAX_POINTS:
        raise ValueError(
            f"scene has {x0.shape[0]} starting points, over the budget of {MAX_POINTS}"
        )
    if samples * x0.shape[0] * n > MAX_SAMPLE_VALUES:
        raise ValueError(
            f"scene asks for samples x points x n = {samples * x0.shape[0] * n} numbers per output, "
            f"over the budget of {MAX_SAMPLE_VALUES}"
        )
    if isinstance(d.get("tol", 1e-9), (bool, str)):
        raise ValueError(f"scene key 'tol' must be a number, got {d['tol']!r}")
    tol = check_tolerance(d.get("tol", 1e-9))
    if tol < MIN_FLOW_TOL:
        raise ValueError(
            f"scene key 'tol' = {tol:g} is below {MIN_FLOW_TOL:g} (float64 rounding alone exceeds it)"
        )
    try:
        inertia = check_inertia(inertia, n)
        check_flow_rates(f, inertia, pi0, t_end, name="scene key 'pi0'")
    except ValueError as exc:
        raise ValueError(f"scene: {exc}") from None
    _check_start(f, theta, upsilon, x0, pi0)
    method = d.get("method")
    if method is not None and (not isinstance(method, str) or method not in METHODS):
        raise ValueError(f"scene key 'method' must be one of {sorted(METHODS)}, got {method!r}")
    outputs = d.get("outputs", ["pi", "energy"])
    if not isinstance(outputs, list) or not all(isinstance(o, str) for o in outputs):
        raise ValueError(
            f"scene key 'outputs' must be a list of strings from {list(OUTPUTS)}, got {outputs!r:.80}"
        )
    outputs = tuple(outputs)
    bad = [o for o in outputs if o not in OUTPUTS]
    if bad:
        raise ValueError(f"scene key 'outputs' has unknown entries {bad}; allowed: {list(OUTPUTS)}")
    name = d.get("name", "scene")
    if not isinstance(name, str) or not name.strip() or len(name) > MAX_NAME:
        raise ValueError(
            f"scene key 'name' must be a non-empty string of at most {MAX_NAME} characters, "
            f"got {name!r:.80}"
        )
    return Scene(
        name, f, alg, theta, upsilon, inertia, pot, x0, pi0, t_end, samples, tol, method, outputs
    )


def _check_start(f, theta, upsilon, x0, pi0) -> None:
    """Starting points on the degenerate set Pi_1 (vier12) or outside the chart are refused by name
    (the fast implementation's flags: Delta = 0 to float64 accuracy, max |Im eig ad_x| >= 2 pi)."""
    try:
        res = FastCore().poisson_batch(f, theta, upsilon, x0, pi0)
    except ValueError as exc:
        raise ValueError(f"scene: {exc}") from None
    for mask, what in (
        (
            res.outside_chart,
            "x0 outside the chart of exponential coordinates (|Im eig ad_x| >= 2 pi)",
        ),
        (res.degenerate, "a start on the degenerate set Pi_1 (Delta = det Phi = 0, vier12)"),
    ):
        if mask is not None and np.any(mask):
            k = int(np.flatnonzero(mask)[0])
            raise ValueError(
                f"scene starting point {k} (x0 = {x0[k].tolist()}, pi0 = {pi0[k].tolist()}) is {what}; "
                f"{int(np.sum(mask))} such point(s)"
            )


MAX_SCENE_BYTES = 10 * 2**20
"""Loader budget: a scene file is at most 10 MiB."""


MAX_NESTING = 32
"""Deepest nesting of tables and arrays accepted in a scene (a scene needs 4)."""


def read_regular_file(
    path, *, what: str = "file", max_bytes: int = MAX_SCENE_BYTES, empty_ok: bool = False
) -> bytes:
    """The bytes of ``path``, read only from a regular file of 1..``max_bytes`` bytes.

    The limit holds while reading (a file growing under us, ``/dev/zero``); a FIFO, a device
    or a folder is refused without reading (opened non-blocking: a FIFO with no writer never
    blocks). Every refusal is a ``ValueError`` naming the path and the condition.
    """
    name = os.fspath(path) if isinstance(path, (str, bytes, os.PathLike)) else None
    if not isinstance(name, str) or not name or "\x00" in name:
        raise ValueError(f"{what}: expected a file path, got {path!r:.80}")
    try:
        fd = os.open(name, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise ValueError(f"{what} {name}: cannot read: {exc.strerror}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            kind = (
                "a folder"
                if stat.S_ISDIR(st.st_mode)
                else "a FIFO"
                if stat.S_ISFIFO(st.st_mode)
                else "a device"
                if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)
                else "not a regular file"
            )
            raise ValueError(f"{what} {name}: is {kind}; only regular files are read")
        chunks, size = [], 0
        while True:
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                break
            size += len(chunk)
            if size > max_bytes:
                raise ValueError(f"{what} {name}: larger than the limit of {max_bytes} bytes")
            chunks.append(chunk)
    finally:
        os.close(fd)
    if size == 0 and not empty_ok:
        raise ValueError(f"{what} {name}: is empty")
    return b"".join(chunks)


def nesting_depth(obj) -> int:
    """Nesting depth of dicts and lists, without recursion."""
    deepest, stack = 0, [(obj, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, dict):
            v = list(v.values())
        if isinstance(v, list):
            deepest = max(deepest, d)
            if d > MAX_NESTING:
                return d
            stack.extend((x, d + 1) for x in v)
    return deepest


def load_scene(path) -> Scene:
    """Read and validate a TOML scene file: a regular file of at most :data:`MAX_SCENE_BYTES`,
    nested at most :data:`MAX_NESTING` deep (:func:`read_regular_file`)."""
    data = read_regular_file(path, what="scene file", max_bytes=MAX_SCENE_BYTES)
    try:
        d = tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML (not UTF-8: {exc.reason})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise ValueError(f"{path}: nested too deeply (at most {MAX_NESTING} levels)") from None
    if nesting_depth(d) > MAX_NESTING:
        raise ValueError(f"{path}: nested too deeply (at most {MAX_NESTING} levels)")
    return parse_scene(d)


def _model(scene: Scene) -> NumpyModel:
    return NumpyModel(
        scene.algebra if scene.algebra is not None else scene.f,
        scene.theta,
        scene.upsilon,
        scene.inertia,
        scene.potential,
    )


def plan(scene: Scene) -> Plan:
    """Choose system, method and step count; record what is skipped and why (module docstring)."""
    model = _model(scene)
    skipped, reasons = [], []
    needs_config = any(o in scene.outputs for o in ("x", "momentum_map"))
    if needs_config:
        system = "full"
        reasons.append(
            "configuration integrated: outputs ask for "
            + ", ".join(o for o in ("x", "momentum_map") if o in scene.outputs)
        )
    else:
        system = "body"
        if model.gravity:
            skipped.append(
                "configuration integration: gravity enters only through Gamma = Ad(g)^T gamma, "
                "so the reduced Euler-Poisson system (pi, Gamma) is integrated (twee17, twee18)"
            )
        else:
            skipped.append(
                "configuration integration: V = 0, the body equations for pi are closed (twee14/drie6)"
            )
    phi = not model.upsilon_zero
    if not phi:
        skipped.append("Phi solve: Upsilon = 0 gives Phi = 1 (vier6), Omega = dK/dpi")
    if scene.method is not None:
        name = scene.method
        ok, why = METHODS[name].applies(model)
        if not ok:
            raise ValueError(f"scene method {name!r} does not apply: {why}")
        reasons.append(f"method {name} requested by the scene")
    elif phi and _rational_taylor_applies(model, system):
        name = "taylor-rational"
        reasons.append(
            "Upsilon != 0, a rational field: the compiled adaptive Taylor method with the solve by "
            "Phi as a series recurrence (numba; order and steps per trajectory from the tolerance), "
            "two runs per trajectory keep every trajectory within tol (refimpl._compiled_rational)"
        )
    elif phi:
        name = "gauss6"
        reasons.append("Upsilon != 0: Gauss-Legendre (order 6) keeps omega_L's structure")
    elif _adaptive_taylor_applies(model, system):
        name = "taylor"
        reasons.append(
            "Upsilon = 0, a quadratic polynomial field: the compiled adaptive Taylor method (numba; "
            "order and steps per trajectory from the tolerance, Jorba-Zou), two runs per trajectory "
            "keep every trajectory within tol (refimpl._flow_compiled)"
        )
    elif METHODS["splitting4"].applies(model)[0] and scene.tol >= 1e-6:
        name = "splitting4"
        reasons.append(
            "su(2), Upsilon = 0, principal axes, loose tolerance: Lie-Poisson splitting (exact "
            "Casimirs, cheapest steps)"
        )
    elif system == "body" and scene.pi0.shape[0] <= 16 and METHODS["taylor20"].applies(model)[0]:
        name = "taylor20"
        reasons.append(
            "few trajectories of a quadratic body system (Upsilon = 0): Taylor series of order 20 "
            "from exact Cauchy-product recurrences, generated straight-line scalar code (fewest "
            "operations per digit; numpy's per-call overhead would dominate arrays of 6 numbers)"
        )
    elif system == "body" and scene.pi0.shape[0] == 1:
        name = "dop853-scalar"
        reasons.append(
            "one trajectory of a polynomial body system: DOP853 as generated straight-line scalar "
            "code (numpy's per-call overhead would dominate arrays of 6 numbers)"
        )
    else:
        name = "dop853"
        reasons.append("explicit 8th-order RK (DOP853 tableau), batched over the trajectories")
    if METHODS[name].adaptive:  # no pilot: the steps follow from tol per trajectory
        return Plan(system, name, 0, phi, skipped, reasons)
    steps = _pilot_steps(model, METHODS[name], scene, system)
    return Plan(system, name, steps, phi, skipped, reasons)


def _adaptive_taylor_applies(model, system: str) -> bool:
    """The compiled adaptive Taylor method covers the body systems with ``Upsilon = 0`` and the su(2)
    full state (:func:`refimpl._flow_compiled.supports_full`), when numba is importable."""

    if not (_compiled_taylor.HAVE_NUMBA and model.upsilon_zero):
        return False
    return system == "body" or supports_full(model)


def _rational_taylor_applies(model, system: str) -> bool:
    """The compiled rational Taylor method covers the body systems with ``Upsilon != 0`` and the su(2)
    full state, when numba is importable."""

    return _compiled_taylor.HAVE_NUMBA and (system == "body" or bool(model.su2))


def _pilot_steps(model, meth, scene, system) -> int:
    dt_sample = scene.t_end / (scene.samples - 1)
    tp = min(scene.t_end, 1.0)
    X, P = scene.x0.T.copy(), scene.pi0.T.copy()
    N = 2
    prev = integrate_fast(model, meth, X, P, tp, N, system=system)
    for _ in range(16):
        cur = integrate_fast(model, meth, X, P, tp, 2 * N, system=system)
        est = float(np.max(np.abs(cur["pi"] - prev["pi"]))) / (2**meth.order - 1)
        if est <= scene.tol * tp / scene.t_end:
            break
        prev, N = cur, 2 * N
    h = tp / (2 * N)
    return max(1, int(np.ceil(dt_sample / h)))


def plot_trajectory(out: dict, title: str):
    """The figure of a run (``run_scene``'s output, or any dict with ``times`` ``(T,)`` and ``pi``
    ``(T, N, n)``, optionally ``energy``, ``casimir ...``, ``momentum_map``): the body momenta of
    trajectory 0, and the drift ``|I(t) - I(0)|`` of every conserved quantity (worst trajectory,
    log scale). Returns the matplotlib figure (``tstarg run`` saves it as ``trajectory.png``; a
    notebook shows it). The title is wrapped and the legends sit beside the axes, off the data
    (``tests/test_figures.py`` checks both)."""

    import matplotlib.pyplot as plt  # heavy, and only for figures: imported when one is drawn

    t = out["times"]
    fig, axes = plt.subplots(2, 1, figsize=(9, 7), constrained_layout=True)
    outside = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}
    pi = np.asarray(out["pi"])[:, 0, :]
    for a in range(pi.shape[1]):
        axes[0].plot(t, pi[:, a], label=f"pi_{a}")
    axes[0].set_xlabel("t")
    axes[0].set_ylabel("body momenta (trajectory 0)")
    axes[0].legend(**outside)
    axes[0].set_title(textwrap.fill(title, 80), fontsize=10)
    drawn = False
    for key, v in out.items():
        if key == "energy" or key.startswith("casimir") or key == "momentum_map":
            arr = np.asarray(v)
            d = np.abs(arr - arr[0])
            d = d.reshape(d.shape[0], -1)
            # NaN rows (outside the chart) are left out of the worst case
            worst = np.max(np.where(np.isfinite(d), d, -np.inf), axis=1)
            worst = np.where(np.isfinite(worst), worst, np.nan)
            axes[1].semilogy(t, np.maximum(worst, 1e-17), label=key)
            drawn = True
    axes[1].set_xlabel("t")
    axes[1].set_ylabel("|I(t) - I(0)| (worst trajectory)")
    if drawn:
        axes[1].legend(**outside)
    return fig


def describe_path(method: str, path: str) -> str:
    """What ran, for the ``path:`` line of ``tstarg run``: the ``path`` reported by the
    integrator (``"numba"``, ``"python"``, ``"numpy"``) and the method it ran."""
    if path == "numba":
        return "numba (compiled Taylor kernels)"
    if path == "python":
        return "python (the Taylor kernels as plain Python: numba is not importable)"
    if method in ("taylor20", "dop853-scalar"):
        return "numpy (generated scalar Python for single-trajectory body systems)"
    return f"numpy (batched over the trajectories, {method})"


def run_scene(scene: Scene, the_plan: Plan | None = None, progress=None) -> dict:
    """Execute the plan; returns times and the requested outputs (arrays over (T, N, ...)), and
    ``"path"``: the line :func:`describe_path` writes for what ran (a string, not an array)."""

    p = the_plan or plan(scene)
    f_in = scene.algebra if scene.algebra is not None else scene.f
    tr = fast_trajectory(
        f_in,
        scene.theta,
        scene.upsilon,
        scene.inertia,
        scene.potential,
        scene.x0,
        scene.pi0,
        scene.t_end,
        scene.samples,
        p.steps_per_sample,
        method_name=p.method,
        system=p.system,
        progress=progress,
        tol=scene.tol,
    )
    out = {"times": tr["times"], "pi": tr["pi"]}
    out["path"] = describe_path(p.method, tr.get("path", "numpy"))
    if tr["Gamma"] is not None:
        out["Gamma"] = tr["Gamma"]
    if tr["x"] is not None:
        out["x"] = tr["x"]
    if "energy" in scene.outputs:
        out["energy"] = energy(scene.inertia, scene.potential, tr["pi"], tr["Gamma"])
    if "casimirs" in scene.outputs:
        try:
            for k, v in casimirs(scene.f, scene.theta, tr["pi"], tr["Gamma"]).items():
                out["casimir " + k] = v
        except ValueError as exc:
            out["note casimirs"] = str(exc)
    if "momentum_map" in scene.outputs:
        if scene.potential is not None:
            out["note momentum_map"] = (
                "the momentum map is conserved only for V = 0; reported anyway"
            )
        T, N, n = tr["pi"].shape
        J = np.full((T, N, n), np.nan)
        for i in range(T):
            for j in range(N):
                if np.all(np.isfinite(tr["x"][i, j])):
                    J[i, j] = momentum_map(f_in, scene.theta, tr["x"][i, j], tr["pi"][i, j])
        out["momentum_map"] = J
    return out
