"""Work-precision machinery for ``tstarg bench``: problems, error ladders, timings, Pareto fronts, figures.

A work-precision point is ``(method, setting, error, time)``:

* ``error``: the worst component of ``|y(T) - y_ref(T)|`` for one trajectory, ``y = (pi, Gamma)``
  (Euler-Poisson, twee17 sign-corrected, twee18) or ``y = pi`` (free top, twee14), against an
  mpmath reference: Gragg-Bulirsch-Stoer at ``ref_dps`` digits confirmed by a precision ladder
  (:func:`refimpl.flows.reference_trajectory` with ``check=True``) or, for the free asymmetric
  top, Jacobi's elliptic-function solution (:func:`refimpl.flows.euler_top_closed_form`).
* ``time``: the minimum over repeats, after a warm-up run of the method, of the CPU time of one
  call (``time.process_time``; the wall-clock minimum is recorded too), measured serially in the
  calling process. Repeats of all points are interleaved (round r times every point once) so that
  load from other processes hits every method alike.

Errors are deterministic functions of ``(problem, method, setting)``: they are computed by tasks
that :func:`reports._parallel.map_tasks` may run anywhere (local processes, Dask). Times are not,
and are never measured in parallel.

Pareto front: a point ``p`` is dominated when another point ``q`` has ``time_q <= time_p`` and
``error_q <= error_p`` with at least one strict; the front is the set of non-dominated points.
"""

from __future__ import annotations

import inspect
import math
import textwrap
import time
from dataclasses import dataclass, field

import mpmath
import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from tstarg.refimpl import catalogue, quadratic_field
from tstarg.refimpl.fast import Fast
from tstarg.refimpl.flows import (
    METHODS,
    NumpyModel,
    euler_top_closed_form,
    integrate_fast,
    reference_trajectory,
    scalar_rhs,
)
from tstarg.refimpl.reference import Reference

from .jsonl import CommandImplementation

__all__ = [
    "ERROR_TARGETS",
    "EXTRA_PROBLEMS",
    "FLOW_PROBLEMS",
    "SCIPY_SOLVERS",
    "TILED",
    "FlowProblem",
    "batch_error_task",
    "batch_initial",
    "bracket_call",
    "bracket_cases",
    "bracket_error_task",
    "fast_methods",
    "impl_body_state",
    "impl_bracket_calls",
    "impl_flow_call",
    "impl_flow_setting",
    "impl_ladder",
    "impl_time_at",
    "bracket_error_of_task",
    "flow_error",
    "flow_problem",
    "fmt_err",
    "fmt_time",
    "ladder_task",
    "own_front",
    "pareto_front",
    "batch_figure",
    "heyoka_version",
    "plot_batch",
    "plot_work_precision",
    "work_precision_figure",
    "reference_task",
    "run_fast",
    "run_scipy",
    "scipy_initial",
    "scipy_rhs",
    "step_ladder",
    "time_at_error",
    "time_points",
]

SCIPY_SOLVERS = ("DOP853", "RK45", "Radau")
TILED = (
    10_000  # points in the large fast batch of the bracket benchmark (the case's points repeated)
)
ERROR_TARGETS = (1e-6, 1e-9, 1e-12)
TOL_LADDER = (
    1e-4,
    1e-6,
    1e-8,
    1e-10,
    1e-12,
    1e-13,
    1e-14,
    1e-15,
    1e-16,
)  # adaptive methods (tstarg, heyoka)
TOL_LADDER_QUICK = (1e-6, 1e-10)


# ------------------------------------------------------------------ Pareto front and curves
def pareto_front(times, errors) -> np.ndarray:
    """Boolean mask of the points not dominated in ``(time, error)`` (both smaller is better).

    Sweep in increasing time (ties: increasing error); a point is on the front when its error is
    strictly below every error seen at a strictly smaller time and below every error of an
    earlier point with the same time. Non-finite errors or times are never on the front.
    """
    t = np.asarray(times, dtype=float).ravel()
    e = np.asarray(errors, dtype=float).ravel()
    if t.shape != e.shape:
        raise ValueError(f"times and errors must have the same length, got {t.shape} and {e.shape}")
    ok = np.isfinite(t) & np.isfinite(e)
    mask = np.zeros(t.shape, dtype=bool)
    idx = [i for i in np.lexsort((e, t)) if ok[i]]
    best = math.inf  # smallest error among points with time strictly smaller than the current group
    k = 0
    while k < len(idx):
        j = k
        while j < len(idx) and t[idx[j]] == t[idx[k]]:
            j += 1
        group = idx[k:j]  # same time, sorted by error
        emin = e[group[0]]
        if emin < best:
            for i in group:
                if e[i] == emin:  # equal points do not dominate each other
                    mask[i] = True
        best = min(best, emin)
        k = j
    return mask


def own_front(times, errors) -> tuple[np.ndarray, np.ndarray]:
    """One method's curve as a monotone staircase: its own Pareto points sorted by time
    (time increasing, error strictly decreasing)."""
    t = np.asarray(times, dtype=float)
    e = np.asarray(errors, dtype=float)
    m = pareto_front(t, e)
    order = np.argsort(t[m])
    return t[m][order], e[m][order]


def time_at_error(times, errors, target: float) -> float:
    """Time a method needs for error ``target``, read off its own front by linear interpolation of
    ``log time`` against ``log error`` between the two points bracketing the target.

    Returns the time of the cheapest point when that point is already at least as accurate as
    ``target`` (an upper bound: the method is not resolved below its cheapest setting), and NaN
    when no point reaches ``target`` (not reached).
    """
    t, e = own_front(times, errors)
    if len(t) == 0 or not e[-1] <= target:
        return math.nan
    if e[0] <= target:
        return float(t[0])
    k = int(np.flatnonzero(e <= target)[0])  # e[k-1] > target >= e[k]
    le0, le1 = math.log(e[k - 1]), math.log(e[k])
    lt0, lt1 = math.log(t[k - 1]), math.log(t[k])
    s = (math.log(target) - le0) / (le1 - le0)
    return float(math.exp(lt0 + s * (lt1 - lt0)))


# ------------------------------------------------------------------ flow problems
@dataclass
class FlowProblem:
    """A body-system flow problem (su(2), Upsilon = 0 unless stated) with its reference."""

    name: str
    title: str
    algebra: str
    inertia: list
    potential: dict | None
    x0: list
    pi0: list
    T: float
    reference: str  # "gbs" (GBS with precision ladder) or "closed" (Jacobi elliptic functions)
    theta_xi: list | None = None  # Theta = -xi.f (a coboundary, zeven3)
    upsilon_tau: list | None = (
        None  # Upsilon^mn = tau_l f^l_mn (su(2): tau_l epsilon_lmn, section cinq)
    )
    notes: list = field(default_factory=list)

    def arrays(self):
        alg = catalogue(self.algebra)
        n = alg.f.shape[0]
        theta = (
            np.zeros((n, n))
            if self.theta_xi is None
            else -np.einsum("k,kab->ab", np.array(self.theta_xi), alg.f)
        )
        pot = (
            None
            if self.potential is None
            else {
                "kind": self.potential["kind"],
                "L": np.array(self.potential["L"], dtype=float),
                "gamma": np.array(self.potential["gamma"], dtype=float),
            }
        )
        up = (
            np.zeros((n, n))
            if self.upsilon_tau is None
            else np.einsum("l,lmn->mn", np.array(self.upsilon_tau), alg.f)
        )
        return alg, theta, up, np.array(self.inertia, dtype=float), pot

    def model(self):
        alg, th, up, inertia, pot = self.arrays()
        return NumpyModel(alg, th, up, inertia, pot)

    def y0(self) -> np.ndarray:
        """The body state at t = 0: ``pi0`` and, with gravity, ``Gamma0 = Ad(exp(x0))^T gamma`` (twee16)."""
        alg, _, _, _, pot = self.arrays()
        pi0 = np.array(self.pi0, dtype=float)
        if pot is None:
            return pi0
        adx = np.einsum("a,mab->mb", np.array(self.x0, dtype=float), alg.f)
        return np.concatenate([pi0, expm(adx).T @ pot["gamma"]])


def flow_problem(name: str, quick: bool = False) -> FlowProblem:
    """The named problem; ``quick`` shortens the time span (t = 10) for test runs."""
    if name == "heavy_top":
        p = FlowProblem(
            "heavy_top",
            "heavy symmetric top (su(2), I = diag(1, 1, 0.5), L = e3, gamma = -e3)",
            "su(2)",
            [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 0.5]],
            {"kind": "gravity", "L": [0.0, 0.0, 1.0], "gamma": [0.0, 0.0, -1.0]},
            [0.1, 0.2, 0.0],
            [0.3, 0.2, 2.0],
            100.0,
            "gbs",
        )
    elif name == "free_top":
        p = FlowProblem(
            "free_top",
            "free asymmetric top (su(2), I = diag(1, 2, 3), V = 0, near the separatrix)",
            "su(2)",
            [[1.0, 0, 0], [0, 2.0, 0], [0, 0, 3.0]],
            None,
            [0.0, 0.0, 0.0],
            [1.0, 0.5, 2.0],
            100.0,
            "closed",
        )
    elif name == "asym_heavy_top":
        p = FlowProblem(
            "asym_heavy_top",
            "heavy asymmetric top (su(2), I = diag(1, 1.3, 0.5), L = (0.1, 0, 1), gamma = -e3; the "
            "'asymmetric' top of tests/benchmarks/test_bench_flows.py: no constant component)",
            "su(2)",
            [[1.0, 0, 0], [0, 1.3, 0], [0, 0, 0.5]],
            {"kind": "gravity", "L": [0.1, 0.0, 1.0], "gamma": [0.0, 0.0, -1.0]},
            [0.1, 0.2, 0.0],
            [0.3, 0.2, 2.0],
            100.0,
            "gbs",
        )
    elif name == "modified_top":
        p = FlowProblem(
            "modified_top",
            "heavy asymmetric top under omega_L (su(2), Theta = -xi.f, xi = (0.1, -0.2, 0.3), "
            "Upsilon = tau.eps, tau = (0.05, 0.1, -0.05), I = diag(1, 2, 3), L = e3, gamma = -e3)",
            "su(2)",
            [[1.0, 0, 0], [0, 2.0, 0], [0, 0, 3.0]],
            {"kind": "gravity", "L": [0.0, 0.0, 1.0], "gamma": [0.0, 0.0, -1.0]},
            [0.1, 0.2, 0.0],
            [0.3, 0.2, 1.0],
            20.0,
            "gbs",
            theta_xi=[0.1, -0.2, 0.3],
            upsilon_tau=[0.05, 0.1, -0.05],
        )
    else:
        raise ValueError(
            f"unknown flow problem {name!r}; known: {', '.join(FLOW_PROBLEMS + EXTRA_PROBLEMS)}"
        )
    if quick:
        p.T = 10.0
    return p


FLOW_PROBLEMS = ("heavy_top", "free_top")  # the default run
EXTRA_PROBLEMS = (
    "modified_top",  # Upsilon != 0, vier10/vier11 with Phi solves
    "asym_heavy_top",  # the heavy top without a constant component (no pi_3 dropped from the products)
)  # on request (--problems)


def reference_task(item) -> dict:
    """Task: the reference end state of a problem. ``item = (name, quick, dps, check)``.

    Returns the components as decimal strings at the reference precision and, for GBS, the digits
    on which a second run at ``dps + 15`` digits agrees (``check``)."""
    name, quick, dps, check = item
    p = flow_problem(name, quick)
    alg, th, up, inertia, pot = p.arrays()
    t0 = time.perf_counter()
    if p.reference == "closed":
        with mpmath.workdps(dps + 10):
            y = euler_top_closed_form(np.diag(inertia).tolist(), p.pi0, p.T)
            vals = [mpmath.nstr(v, dps + 5) for v in y]
        digits, how = (
            None,
            f"Jacobi elliptic functions (refimpl.flows.euler_top_closed_form) at {dps + 10} digits",
        )
    else:
        tr = reference_trajectory(
            alg, th, up, inertia, pot, p.x0, p.pi0, [0, p.T], dps=dps, system="body", check=check
        )
        comps = list(tr.pi[-1]) + ([] if tr.Gamma is None else list(tr.Gamma[-1]))
        with mpmath.workdps(dps + 15):
            vals = [mpmath.nstr(v, dps + 5) for v in comps]
        digits = tr.digits
        how = (
            f"Gragg-Bulirsch-Stoer at {dps} digits (refimpl.flows.reference_trajectory, body system)"
            + (f"; a run at {dps + 15} digits agrees to {digits:.1f} digits" if check else "")
        )
    return {
        "problem": name,
        "values": vals,
        "digits": digits,
        "how": how,
        "seconds": time.perf_counter() - t0,
    }


def fast_methods(model) -> tuple[list[str], dict[str, str]]:
    """Names of :data:`refimpl.flows.METHODS` to benchmark on a body system, and the skipped ones with why.

    Picked up dynamically: a method whose ``applies(model)`` is False is skipped with its reason;
    an RKMK variant is skipped on the body system because there it is the same computation as its
    base Runge-Kutta method (the Munthe-Kaas re-basing acts on the configuration only)."""
    names, skipped = [], {}
    for name, meth in METHODS.items():
        ok, why = meth.applies(model)
        if not ok:
            skipped[name] = why
        elif getattr(meth, "rkmk", False):
            skipped[name] = (
                "RKMK re-bases the configuration only: on the body system it equals its base RK"
            )
        else:
            names.append(name)
    return names, skipped


def step_ladder(order: int | None, N0: int, N_max: int) -> list[int]:
    """Step counts from ``N0`` to ``N_max`` growing by ``2^min(1, 8/order)`` per rung, so that one
    rung lowers an order-``p`` method's error by about ``2^8`` at most (high-order methods get more
    rungs; order unknown: doubling)."""
    factor = 2.0 ** min(1.0, 8.0 / order) if order else 2.0
    out = [int(N0)]
    while round(out[-1] * factor) <= N_max:
        out.append(max(out[-1] + 1, round(out[-1] * factor)))
    return out


def tol_ladder(quick: bool) -> list[float]:
    """Tolerances walked by the adaptive methods (tstarg ``taylor``, heyoka ``taylor_adaptive``)."""
    return list(TOL_LADDER_QUICK if quick else TOL_LADDER)


def heyoka_version() -> str | None:
    """heyoka's version, or None when it is not importable."""
    try:
        import heyoka  # optional contender (the bench extra)
    except ImportError:
        return None
    return str(heyoka.__version__)


def have_heyoka() -> bool:
    try:
        import heyoka  # noqa: F401 - optional contender (the bench extra)
    except ImportError:
        return False
    return True


_HEYOKA: dict = {}
HEYOKA_COMPILE: dict = {}  # (problem, tol) -> CPU seconds of heyoka's JIT compilation (reported apart)


def heyoka_integrator(problem: FlowProblem, model, tol: float):
    """heyoka's ``taylor_adaptive`` on the same body field, built and JIT-compiled once per tolerance:
    the polynomial of :func:`refimpl._taylor.quadratic_field` when ``Upsilon = 0``, else the rational
    field of :func:`heyoka_rational_rhs` (vier10/vier11 through the adjugate and determinant of Psi).
    The compile time is recorded in :data:`HEYOKA_COMPILE`, apart from the run times."""
    import heyoka as hy  # optional contender

    key = (problem.name, problem.T, float(tol))
    if key in _HEYOKA:
        return _HEYOKA[key]
    if model.upsilon_zero:
        F = quadratic_field(model)
        ys = hy.make_vars(*[f"y{c}" for c in range(F.d)])
        rhs = []
        for c in range(F.d):
            e = 0.0 * ys[0]
            for (i, j), q in F.quad[c].items():
                e = e + float(q) * ys[i] * ys[j]
            for i, q in F.lin[c].items():
                e = e + float(q) * ys[i]
            rhs.append(e)
    else:
        ys, rhs = heyoka_rational_rhs(model)
    y0 = problem.y0()
    t0 = time.process_time()
    ta = hy.taylor_adaptive(list(zip(ys, rhs)), y0.tolist(), tol=float(tol))
    HEYOKA_COMPILE[key] = time.process_time() - t0
    _HEYOKA[key] = (ta, y0)
    return _HEYOKA[key]


def _hy_sum(terms):
    """Sum of heyoka expressions (``coef, expr``) with the zero coefficients left out (None if empty)."""
    out = None
    for c, e in terms:
        if c == 0.0:
            continue
        t = e if c == 1.0 else float(c) * e
        out = t if out is None else out + t
    return out


def _hy_det(M):
    """Determinant of a small square matrix of heyoka expressions (None = 0) by cofactor expansion."""
    n = len(M)
    if n == 1:
        return M[0][0]
    terms = []
    for j in range(n):
        if M[0][j] is None:
            continue
        md = _hy_det([[M[i][c] for c in range(n) if c != j] for i in range(1, n)])
        if md is not None:
            terms.append((1.0 if j % 2 == 0 else -1.0, M[0][j] * md))
    return _hy_sum(terms)


def heyoka_rational_rhs(model):
    """The body field with ``Upsilon != 0`` in heyoka expressions (vier10/vier11, as
    :meth:`refimpl.model.Model.omega_pidot`): ``Psi = 1 + Upsilon S(pi)``, ``Omega = adj(Psi) (dK -
    Upsilon dV) / det Psi``, ``pidot = adj(Psi)^T (-dV - S dK) / det Psi`` (``Phi = Psi^T``), ``Gammadot_mu =
    Omega^b f^a_{b mu} Gamma_a``. Written for ``n <= 4`` (cofactor expansion); returns ``(vars, rhs)``."""
    import heyoka as hy  # optional contender

    n = model.n
    if n > 4:
        raise ValueError(
            f"heyoka_rational_rhs: written for n <= 4 (cofactor expansion), got n = {n}"
        )
    grav = model.gravity
    ys = hy.make_vars(*[f"y{c}" for c in range(2 * n if grav else n)])
    pi, G = ys[:n], (ys[n:] if grav else None)
    f, th, U, Ii = model.f, model.theta, model.upsilon, model.Iinv
    S = [[_hy_sum([(f[m, a, b], pi[m]) for m in range(n)]) for b in range(n)] for a in range(n)]
    S = [
        [
            (S[a][b] - float(th[a, b]) if S[a][b] is not None else hy.expression(-float(th[a, b])))
            if th[a, b] != 0.0
            else S[a][b]
            for b in range(n)
        ]
        for a in range(n)
    ]
    Psi = []
    for a in range(n):
        row = []
        for b in range(n):
            e = _hy_sum([(U[a, c], S[c][b]) for c in range(n) if S[c][b] is not None])
            if a == b:
                e = hy.expression(1.0) if e is None else 1.0 + e
            row.append(e)
        Psi.append(row)
    det = _hy_det(Psi)
    # adj(Psi)_ab = (-1)^(a+b) det(minor_ba)
    adj = [[None] * n for _ in range(n)]
    for a in range(n):
        for b in range(n):
            minor = [[Psi[i][c] for c in range(n) if c != a] for i in range(n) if i != b]
            md = _hy_det(minor) if n > 1 else hy.expression(1.0)
            adj[a][b] = None if md is None else (md if (a + b) % 2 == 0 else -md)
    dK = [_hy_sum([(Ii[a, b], pi[b]) for b in range(n)]) for a in range(n)]
    dV = (
        [_hy_sum([(-model.G_L[a, b], G[b]) for b in range(n)]) for a in range(n)]
        if grav
        else [None] * n
    )
    ro = []
    for a in range(n):
        t = [(1.0, dK[a])] if dK[a] is not None else []
        t += [(-U[a, b], dV[b]) for b in range(n) if dV[b] is not None]
        ro.append(_hy_sum(t))
    rp = []
    for a in range(n):
        t = [(-1.0, dV[a])] if dV[a] is not None else []
        for b in range(n):
            if S[a][b] is not None and dK[b] is not None:
                t.append((-1.0, S[a][b] * dK[b]))
        rp.append(_hy_sum(t))
    zero = hy.expression(0.0)

    def solve(r, transpose: bool):
        """``adj(Psi) r / det`` (or with ``adj(Psi)^T``), zero entries left out."""
        out = []
        for a in range(n):
            terms = []
            for b in range(n):
                m = adj[b][a] if transpose else adj[a][b]
                if m is not None and r[b] is not None:
                    terms.append((1.0, m * r[b]))
            s = _hy_sum(terms)
            out.append((s if s is not None else zero) / det)
        return out

    Om = solve(ro, False)
    pd = solve(rp, True)
    rhs = list(pd)
    if grav:
        for mu in range(n):
            t = [
                (f[a, b, mu], Om[b] * G[a])
                for a in range(n)
                for b in range(n)
                if f[a, b, mu] != 0.0
            ]
            e = _hy_sum(t)
            rhs.append(zero if e is None else e)
    return ys, rhs


def run_heyoka(problem: FlowProblem, model, tol: float) -> np.ndarray:
    """End state ``(d, 1)`` of heyoka's adaptive Taylor integrator at tolerance ``tol`` (reset, propagate)."""
    ta, y0 = heyoka_integrator(problem, model, tol)
    ta.time = 0.0
    ta.state[:] = y0
    ta.propagate_until(float(problem.T))
    return np.array(ta.state)[:, None]


def heyoka_batch_integrator(problem: FlowProblem, model, tol: float, width: int | None = None):
    """heyoka's ``taylor_adaptive_batch`` (SIMD width ``width``, default heyoka's recommended one) on the
    body field of :func:`heyoka_integrator`, JIT-compiled once per tolerance (compile time in
    :data:`HEYOKA_COMPILE` under ``(name, T, tol, "batch")``). Returns ``(ta, width)``."""
    import heyoka as hy  # optional contender

    width = int(width or hy.recommended_simd_size())
    key = (problem.name, problem.T, float(tol), "batch", width)
    if key in _HEYOKA:
        return _HEYOKA[key]
    F = quadratic_field(model)
    ys = hy.make_vars(*[f"y{c}" for c in range(F.d)])
    rhs = []
    for c in range(F.d):
        e = 0.0 * ys[0]
        for (i, j), q in F.quad[c].items():
            e = e + float(q) * ys[i] * ys[j]
        for i, q in F.lin[c].items():
            e = e + float(q) * ys[i]
        rhs.append(e)
    y0 = np.repeat(problem.y0()[:, None], width, axis=1)
    t0 = time.process_time()
    ta = hy.taylor_adaptive_batch(list(zip(ys, rhs)), y0, tol=float(tol))
    HEYOKA_COMPILE[key[:4]] = time.process_time() - t0
    _HEYOKA[key] = (ta, width)
    return _HEYOKA[key]


def run_heyoka_batch(problem: FlowProblem, model, tol: float, Y0: np.ndarray) -> np.ndarray:
    """End states ``(d, M)`` of heyoka's batch integrator for the body states ``Y0`` (d, M), ``width``
    trajectories per call (the last chunk padded with copies of its first column); each trajectory
    keeps its own step size (heyoka's batch mode)."""
    ta, W = heyoka_batch_integrator(problem, model, tol)
    d, M = Y0.shape
    out = np.empty((d, M))
    T = float(problem.T)
    for k in range(0, M, W):
        chunk = Y0[:, k : k + W]
        m = chunk.shape[1]
        ta.set_time(0.0)
        if m < W:
            chunk = np.concatenate([chunk, np.repeat(chunk[:, :1], W - m, axis=1)], axis=1)
        ta.state[:] = chunk
        ta.propagate_until(T)
        out[:, k : k + m] = ta.state[:, :m]
    return out


def run_fast(problem: FlowProblem, model, name: str, nsteps, y0=None) -> np.ndarray:
    """End state(s) ``(d, N)`` of the fast method ``name`` with ``nsteps`` fixed steps (for an adaptive
    method: ``nsteps`` is its tolerance)."""
    n = model.n
    if y0 is None:
        x0 = np.array(problem.x0, dtype=float)[:, None]
        pi0 = np.array(problem.pi0, dtype=float)[:, None]
    else:
        x0, pi0 = y0
    meth = METHODS[name]
    with np.errstate(
        over="ignore", invalid="ignore"
    ):  # a too coarse step may diverge: error inf, recorded
        if meth.adaptive:
            out = integrate_fast(
                model, meth, x0, pi0, problem.T, None, system="body", tol=float(nsteps)
            )
        else:
            out = integrate_fast(model, meth, x0, pi0, problem.T, int(nsteps), system="body")
    return out["pi"] if out["Gamma"] is None else np.concatenate([out["pi"], out["Gamma"]])[: 2 * n]


def scipy_rhs(model):
    """The right-hand side handed to scipy: the generated scalar body field (``Upsilon = 0``), else the
    numpy body field."""
    if model.upsilon_zero:
        return scalar_rhs(model), "generated scalar Python body field (refimpl.flows.scalar_rhs)"
    F = model.body_rhs()
    return (lambda t, y: F(y[:, None])[:, 0]), "numpy body field (NumpyModel.body_rhs)"


def run_scipy(problem: FlowProblem, rhs, solver: str, rtol: float, y0=None):
    """``solve_ivp`` with ``rtol = atol``; Radau without a Jacobian (scipy's finite differences)."""
    y0 = problem.y0() if y0 is None else y0
    with np.errstate(over="ignore", invalid="ignore"):
        return solve_ivp(rhs, (0.0, problem.T), y0, method=solver, rtol=rtol, atol=rtol)


def flow_error(y, ref) -> float:
    """Worst component of ``|y - y_ref|`` for one trajectory (float64 ``y``; ``ref`` rounded to float64,
    which adds at most ``eps |y_ref| / 2 ~ 1e-16``, far below the smallest errors recorded)."""
    y = np.asarray(y, dtype=float).ravel()
    r = np.asarray([float(v) for v in ref])
    if y.shape != r.shape:
        raise ValueError(f"state has {y.size} components, reference {r.size}")
    d = np.abs(y - r)
    return float(np.max(d)) if np.all(np.isfinite(d)) else math.inf


def ladder_task(item) -> dict:
    """Task: walk one method's ladder and return its error at every setting (no timings).

    ``item = (problem name, quick, kind, method, ladder, reference values, floor, nfev_cap, target_cap)``
    with kind ``"fast"`` (ladder: step counts) or ``"scipy"`` (ladder: rtol = atol values). The walk
    stops (deterministically) when the error reaches ``floor``, when the error stops decreasing
    (two rungs without halving once below 1e-8: round-off), for scipy when ``nfev`` exceeds
    ``nfev_cap``, and for fast methods when the declared order predicts that even the last rung
    cannot reach ``target_cap`` (``e_N (N / N_max)^order > target_cap``).
    """
    name, quick, kind, meth, ladder, ref, floor, nfev_cap, target_cap = item
    p = flow_problem(name, quick)
    model = p.model()
    rhs = scipy_rhs(model)[0] if kind == "scipy" else None
    points, stop, flat = [], "end of ladder", 0
    for k, s in enumerate(ladder):
        extra = {}
        try:
            if kind == "fast":
                y = run_fast(p, model, meth, s)[:, 0]
            elif kind == "heyoka":
                y = run_heyoka(p, model, s)[:, 0]
            else:
                sol = run_scipy(p, rhs, meth, s)
                if not sol.success:
                    stop = f"solve_ivp failed at rtol {s:g}: {sol.message}"
                    break
                y = sol.y[:, -1]
                extra = {"nfev": int(sol.nfev), "njev": int(getattr(sol, "njev", 0) or 0)}
        except (ValueError, FloatingPointError, ArithmeticError) as exc:
            stop = f"{type(exc).__name__} at setting {s}: {exc}"
            break
        err = flow_error(y, ref)
        points.append({"setting": s, "error": err, **extra})
        if not math.isfinite(err):
            continue  # diverged at this step size: recorded with error inf, the finer rungs follow
        if err <= floor:
            stop = f"error <= floor {floor:g}"
            break
        if len(points) >= 2 and points[-2]["error"] < 1e-8 and err > 0.5 * points[-2]["error"]:
            flat += 1
            if flat >= 2:
                stop = "error stopped decreasing (round-off)"
                break
        else:
            flat = 0
        if kind == "scipy" and extra["nfev"] > nfev_cap:
            stop = f"nfev {extra['nfev']} > cap {nfev_cap}"
            break
        order = getattr(METHODS.get(meth), "order", None) if kind == "fast" else None
        if order and k + 1 < len(ladder) and err * (s / ladder[-1]) ** order > target_cap:
            stop = (
                f"order-{order} extrapolation to {ladder[-1]} steps predicts error "
                f"{err * (s / ladder[-1]) ** order:.1e} > {target_cap:g}"
            )
            break
    return {
        "problem": name,
        "kind": kind,
        "method": meth,
        "ladder": list(ladder),
        "points": points,
        "stop": stop,
    }


# ------------------------------------------------------------------ timing
def time_points(
    calls: list,
    *,
    groups: list | None = None,
    max_rounds: int = 7,
    slow: float = 1.0,
    medium: float = 0.1,
    warmed=(),
) -> list[dict]:
    """Best run time of each zero-argument callable, serially in this process.

    Warm-up: before any timing, the first call of each group (``groups[i]`` names call ``i``'s
    group, e.g. its method; default: every call is its own group) runs once untimed, so code
    generation, caches and imports are paid before the clock runs. Then rounds interleave the
    calls; round 0 times every call and sets its number of repeats (7 below ``medium`` seconds,
    3 below ``slow``, 1 above, at most ``max_rounds``); later rounds run only the calls that still
    need repeats.

    Two clocks per run: ``time.process_time`` (CPU time of this process: the runs are single
    threaded with BLAS pinned to one thread, so on an idle machine it equals the wall time, and
    on a shared machine it leaves out the time other processes hold the core) and
    ``time.perf_counter`` (wall). ``warmed``: indices of calls the caller has already run once (their
    groups get no warm-up here). Returns ``{"time": min CPU, "wall": min wall, "repeats"}``.
    """
    groups = list(range(len(calls))) if groups is None else list(groups)
    if len(groups) != len(calls):
        raise ValueError(
            f"groups must name one group per call: {len(groups)} groups for {len(calls)} calls"
        )
    seen = {groups[i] for i in warmed}  # groups whose code already ran once (the caller's warm-up)
    for g, fn in zip(groups, calls):
        if g not in seen:
            seen.add(g)
            fn()
    cpu = [math.inf] * len(calls)
    wall = [math.inf] * len(calls)
    reps = [max_rounds] * len(calls)
    for r in range(max_rounds):
        for i, fn in enumerate(calls):
            if r < reps[i]:
                c0, w0 = time.process_time(), time.perf_counter()
                fn()
                dw = time.perf_counter() - w0
                dc = time.process_time() - c0
                cpu[i], wall[i] = min(cpu[i], dc), min(wall[i], dw)
                if r == 0:
                    reps[i] = min(max_rounds, 7 if dw < medium else 3 if dw < slow else 1)
    return [{"time": c, "wall": w, "repeats": k} for c, w, k in zip(cpu, wall, reps)]


# ------------------------------------------------------------------ brackets
def bracket_cases(quick: bool = False) -> list[dict]:
    """Poisson-tensor problems: su(2) and se(3) with a coboundary Theta = -xi.f (zeven3), a random
    antisymmetric Upsilon and random points away from the degenerate set (cond(Phi) < 1e3).
    Deterministic (``default_rng`` with fixed seeds)."""
    out = []
    for seed, name in enumerate(("su(2)", "se(3)")):
        alg = catalogue(name)
        n = alg.f.shape[0]
        rng = np.random.default_rng(100 + seed)
        A = 0.3 * rng.standard_normal((n, n))
        U = A - A.T
        xi = 0.3 * rng.standard_normal(n)
        th = -np.einsum("k,kab->ab", xi, alg.f)
        m = 3 if quick else 12
        xs, ps = [], []
        while len(xs) < m:
            x = 0.8 * rng.standard_normal(n)
            pi = rng.standard_normal(n)
            r = Fast().poisson_batch(alg.f, th, U, x[None], pi[None])
            if not r.degenerate[0] and r.cond_phi[0] < 1e3:
                xs.append(x)
                ps.append(pi)
        out.append(
            {"algebra": name, "theta": th, "upsilon": U, "x": np.array(xs), "pi": np.array(ps)}
        )
    return out


def _ref_P(alg, th, U, x, pi, dps, route):
    R = Reference(dps)
    P = R.poisson_tensor_mp(alg.f, th, U, x, pi, route=route)
    return P


def bracket_error_task(item) -> float:
    """Task: ``max_ij |P_ij - Pref_ij| / max_ij |Pref_ij|`` at one point, ``Pref`` at ``high`` digits.

    ``item = (case index, quick, point index, kind, dps, route, high)``; kind ``"fast"`` or ``"reference"``."""
    ci, quick, pj, kind, dps, route, high = item
    case = bracket_cases(quick)[ci]
    alg = catalogue(case["algebra"])
    x, pi = case["x"][pj], case["pi"][pj]
    Pref = _ref_P(alg, case["theta"], case["upsilon"], x, pi, high, "closed")
    if kind == "fast":
        P = Fast().poisson_batch(alg.f, case["theta"], case["upsilon"], x[None], pi[None]).P[0]
    else:
        P = _ref_P(alg, case["theta"], case["upsilon"], x, pi, dps, route)
    with mpmath.workdps(high + 10):
        nrm = max(abs(Pref[i, j]) for i in range(Pref.rows) for j in range(Pref.cols))
        num = max(
            abs(mpmath.mpf(P[i, j]) - Pref[i, j])
            for i in range(Pref.rows)
            for j in range(Pref.cols)
        )
        return float(num / nrm)


def bracket_call(case: dict, kind: str, dps: int | None, route: str):
    """A zero-argument callable evaluating the Poisson tensor at every point of ``case`` (for timing)."""
    alg = catalogue(case["algebra"])
    th, U, X, Pi = case["theta"], case["upsilon"], case["x"], case["pi"]
    if kind == "fast":
        F = Fast()
        return lambda: F.poisson_batch(alg.f, th, U, X, Pi)
    if kind == "fast-tiled":
        F = Fast()
        reps = -(-TILED // len(X))
        Xt, Pt = np.tile(X, (reps, 1))[:TILED], np.tile(Pi, (reps, 1))[:TILED]
        return lambda: F.poisson_batch(alg.f, th, U, Xt, Pt)
    if kind == "fast-single":
        F = Fast()
        return lambda: [
            F.poisson_batch(alg.f, th, U, X[i : i + 1], Pi[i : i + 1]) for i in range(len(X))
        ]
    R = Reference(dps)
    return lambda: [
        R.poisson_tensor_mp(alg.f, th, U, X[i], Pi[i], route=route) for i in range(len(X))
    ]


# ------------------------------------------------------------------ batch throughput
def batch_initial(problem: FlowProblem, M: int, seed: int = 3):
    """``M`` initial conditions: ``pi0 + 0.01 N(0, 1)`` with the same ``x0``; trajectory 0 is the
    reference trajectory itself (so its error is judged against mpmath)."""
    rng = np.random.default_rng(seed)
    n = len(problem.pi0)
    pi0 = np.array(problem.pi0, dtype=float)[:, None] + 0.01 * rng.standard_normal((n, M))
    pi0[:, 0] = problem.pi0
    x0 = np.repeat(np.array(problem.x0, dtype=float)[:, None], M, axis=1)
    return x0, pi0


def batch_error_task(item) -> dict:
    """Task: errors of one batched run. ``item = (name, quick, method, steps, M, seed, ref, rtol, sub)``.

    Worst trajectory of the batch against a run with 4x the steps (its own error is ``4^-order``
    times smaller: Richardson), trajectory 0 against the mpmath reference, and scipy DOP853 at
    ``rtol`` on the first ``sub`` trajectories against the same fine run."""
    name, quick, meth, steps, M, seed, ref, rtol, sub = item
    p = flow_problem(name, quick)
    model = p.model()
    x0, pi0 = batch_initial(p, M, seed)
    y = run_fast(p, model, meth, steps, (x0, pi0))
    fine = run_fast(p, model, meth, 4 * steps, (x0, pi0))
    worst = float(np.max(np.abs(y - fine)))
    err0 = flow_error(y[:, 0], ref)
    rhs = scipy_rhs(model)[0]
    Y0 = scipy_initial(p, x0, pi0, sub)
    s_err = 0.0
    for j in range(sub):
        sol = run_scipy(p, rhs, "DOP853", rtol, Y0[:, j])
        s_err = max(s_err, float(np.max(np.abs(sol.y[:, -1] - fine[:, j]))))
    return {
        "M": M,
        "worst_vs_fine": worst,
        "traj0_vs_reference": err0,
        "scipy_worst_vs_fine": s_err,
        "fine_order_factor": 4.0 ** -METHODS[meth].order,
    }


def scipy_initial(problem: FlowProblem, x0, pi0, count: int) -> np.ndarray:
    """Body initial states ``(d, count)`` for scipy: ``pi0`` and ``Gamma0 = Ad(exp(x0))^T gamma``."""
    alg, _, _, _, pot = problem.arrays()
    if pot is None:
        return pi0[:, :count].copy()
    cols = []
    for j in range(count):
        adx = np.einsum("a,mab->mb", x0[:, j], alg.f)
        cols.append(np.concatenate([pi0[:, j], expm(adx).T @ pot["gamma"]]))
    return np.stack(cols, axis=1)


# ------------------------------------------------------------------ figures
def _plt():
    import matplotlib  # heavy and only for figures: loaded when one is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _finish(fig, ax, title: str, width_chars: int) -> None:
    """Title and legend placed so that nothing is cut or covers data: the title is the figure's
    (wrapped to the canvas width, laid out inside it by constrained layout), the legend sits in its
    own column right of the axes."""
    fig.suptitle(textwrap.fill(title, width_chars), fontsize=10)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)


def _save(fig, path) -> None:
    plt = _plt()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_work_precision(
    points: list[dict],
    path,
    title: str,
    *,
    xlabel: str = "CPU time per run [s]",
    targets=ERROR_TARGETS,
) -> None:
    """Error against time, log-log, one line per method (tstarg solid, scipy dashed), the Pareto
    front circled and joined by a grey staircase (:func:`work_precision_figure`), saved to ``path``."""
    _save(work_precision_figure(points, title, xlabel=xlabel, targets=targets), path)


def work_precision_figure(
    points: list[dict], title: str, *, xlabel: str = "CPU time per run [s]", targets=ERROR_TARGETS
):
    """The figure of :func:`plot_work_precision` (returned open, for tests of its layout)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(11, 6.2), layout="constrained")
    methods = list(dict.fromkeys(p["method"] for p in points))
    colors = plt.get_cmap("tab10").colors
    others = plt.get_cmap("Dark2").colors
    counters = {"tstarg": 0, "other": 0}
    for m in methods:
        pts = sorted(
            (
                p
                for p in points
                if p["method"] == m and math.isfinite(p["error"]) and p["error"] > 0
            ),
            key=lambda p: p["time"],
        )
        if not pts:
            continue
        family = "tstarg" if pts[0].get("family", "tstarg") == "tstarg" else "other"
        k = counters[family]
        counters[family] += 1
        ax.loglog(
            [p["time"] for p in pts],
            [p["error"] for p in pts],
            ls="-" if family == "tstarg" else "--",
            marker=("o", "^", "v", "D")[k // 10 % 4]
            if family == "tstarg"
            else "*"  # a third-party contender (bench --impl/--cmd) stands out
            if pts[0].get("family") == "impl"
            else "s",
            ms=9 if pts[0].get("family") == "impl" else 4,
            color=colors[k % 10] if family == "tstarg" else others[(k * 3 + 1) % 8],
            label=m,
        )
    front = sorted(
        (p for p in points if p.get("on_front") and p["error"] > 0), key=lambda p: p["time"]
    )
    if front:
        ft, fe = [p["time"] for p in front], [p["error"] for p in front]
        ax.step(ft, fe, where="post", color="0.4", lw=1, zorder=0)
        ax.scatter(
            ft, fe, s=110, facecolors="none", edgecolors="k", lw=1.3, label="Pareto front", zorder=5
        )
    for tgt in targets:
        ax.axhline(tgt, color="0.8", lw=0.8, ls=":")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("error (worst component vs mpmath reference)")

    ax.grid(True, which="major", alpha=0.3)
    _finish(fig, ax, title, 110)
    return fig


def plot_batch(rows: list[dict], path, title: str) -> None:
    """Time per trajectory against the batch size, ours and scipy's (:func:`batch_figure`)."""
    _save(batch_figure(rows, title), path)


def batch_figure(rows: list[dict], title: str):
    """The figure of :func:`plot_batch` (returned open, for tests of its layout)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(10, 4.5), layout="constrained")
    Ms = [r["M"] for r in rows]
    ax.loglog(Ms, [r["ours_per_traj"] for r in rows], "o-", label=rows[0]["ours_label"])
    ax.loglog(Ms, [r["scipy_per_traj"] for r in rows], "s--", label=rows[0]["scipy_label"])
    ax.set_xlabel("trajectories in the batch")
    ax.set_ylabel("CPU time per trajectory [s]")
    ax.grid(True, which="major", alpha=0.3)
    _finish(fig, ax, title, 100)
    return fig


def fmt_err(e) -> str:
    return "inf (diverged)" if e is None or not math.isfinite(e) else f"{e:.2e}"


def fmt_time(t) -> str:
    if t is None or not math.isfinite(t):
        return "n/a"
    if t < 1e-3:
        return f"{t * 1e6:.1f} us"
    if t < 1:
        return f"{t * 1e3:.2f} ms"
    return f"{t:.2f} s"


# ------------------------------------------------------------------ a third-party implementation
# ``tstarg bench --impl module:object`` / ``--cmd "PROGRAM ARGS"``: an implementation of the
# protocol (docs/design.md; the object ``tstarg certify`` takes) on the same diagrams as ours.


def impl_flow_setting(impl) -> str:
    """How the implementation's ``flow`` can be driven over a work-precision ladder: ``"steps"``
    when it takes the protocol's optional ``steps=`` keyword (docs/design.md: a fixed step count; a
    JSON-lines program is asked for ``steps`` only when its ``capabilities`` declare an ``order``),
    ``"tol"`` when it takes a ``tol=`` keyword, else ``"default"``: one point at its own accuracy."""
    if isinstance(impl, CommandImplementation):
        return "steps" if getattr(impl, "order", None) is not None else "default"
    try:
        params = inspect.signature(impl.flow).parameters
    except (TypeError, ValueError):
        return "default"
    if "steps" in params:
        return "steps"
    if "tol" in params:
        return "tol"
    return "default"


def impl_flow_args(problem: FlowProblem):
    """The protocol arguments ``(f, theta, upsilon, inertia, potential, x0, pi0, t)`` of a problem."""
    alg, th, up, inertia, pot = problem.arrays()
    x0 = np.array(problem.x0, dtype=float)
    pi0 = np.array(problem.pi0, dtype=float)
    return (np.array(alg.f, dtype=float), th, up, inertia, pot, x0, pi0, float(problem.T))


def impl_flow_call(impl, problem: FlowProblem, setting_name: str, setting):
    """A zero-argument callable running the implementation's ``flow`` once on the problem's
    arguments (built once, outside the timed call; the protocol forbids mutating them)."""
    args = impl_flow_args(problem)
    kw = {} if setting_name == "default" else {setting_name: setting}
    return lambda: impl.flow(*args, **kw)


def impl_body_state(problem: FlowProblem, x, pi) -> np.ndarray:
    """The protocol's full state ``(x, pi)`` at ``T`` as the body state the error is judged on:
    ``pi`` and, with gravity, ``Gamma = Ad(exp(x))^T gamma`` (twee16, as :meth:`FlowProblem.y0`)."""
    alg, _, _, _, pot = problem.arrays()
    pi = np.asarray(pi, dtype=float).reshape(-1)
    if pot is None:
        return pi
    x = np.asarray(x, dtype=float).reshape(-1)
    adx = np.einsum("a,mab->mb", x, alg.f)
    return np.concatenate([pi, expm(adx).T @ pot["gamma"]])


def impl_ladder(impl, problem: FlowProblem, ref, floor: float, quick: bool) -> dict:
    """Walk the implementation's ladder (:func:`impl_flow_settings`) in this process and judge every
    setting with :func:`flow_error` against the same reference values as ours.

    Step ladders run from ``N0 = max(4, 1.25 T)`` by the same rule as ours (:func:`step_ladder`,
    the declared order), tolerance ladders over :func:`tol_ladder`; the walk stops as ours does
    (the floor reached, or two rungs without halving once below 1e-8), and at the first error the
    implementation raises (recorded as the stop)."""
    name = impl_flow_setting(impl)
    if name == "steps":
        n0 = max(4, round(1.25 * problem.T))
        ladder = step_ladder(getattr(impl, "order", None), n0, n0 * 2 ** (3 if quick else 6))
    elif name == "tol":
        ladder = tol_ladder(quick)
    else:
        ladder = [None]
    points, stop, flat = [], "end of ladder", 0
    for s in ladder:
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                x, pi = impl_flow_call(impl, problem, name, s)()
            y = impl_body_state(problem, x, pi)
        except Exception as exc:  # noqa: BLE001 - third-party code: any failure ends its ladder, named
            stop = f"{type(exc).__name__} at {name} {s}: {exc}"[:300]
            break
        err = flow_error(y, ref)
        points.append({"setting": s, "error": err})
        if not math.isfinite(err):
            continue
        if err <= floor:
            stop = f"error <= floor {floor:g}"
            break
        if len(points) >= 2 and points[-2]["error"] < 1e-8 and err > 0.5 * points[-2]["error"]:
            flat += 1
            if flat >= 2:
                stop = "error stopped decreasing (round-off)"
                break
        else:
            flat = 0
    return {"setting_name": name, "ladder": ladder, "points": points, "stop": stop}


def impl_time_at(points: list[dict], target: float) -> float:
    """The implementation's time at error ``target`` on its own front (:func:`time_at_error`)."""
    return time_at_error([p["time"] for p in points], [p["error"] for p in points], target)


def bracket_error_of_task(item) -> float:
    """Task: the bracket error (:func:`bracket_error_task`'s measure) of a given float64 tensor.

    ``item = (case index, quick, point index, P as nested lists, high)``; ``P`` non-finite or of the
    wrong shape gives ``inf``."""
    ci, quick, pj, P, high = item
    case = bracket_cases(quick)[ci]
    alg = catalogue(case["algebra"])
    Pref = _ref_P(
        alg, case["theta"], case["upsilon"], case["x"][pj], case["pi"][pj], high, "closed"
    )
    P = np.asarray(P, dtype=float)
    if P.shape != (Pref.rows, Pref.cols) or not np.all(np.isfinite(P)):
        return math.inf
    with mpmath.workdps(high + 10):
        nrm = max(abs(Pref[i, j]) for i in range(Pref.rows) for j in range(Pref.cols))
        num = max(
            abs(mpmath.mpf(float(P[i, j])) - Pref[i, j])
            for i in range(Pref.rows)
            for j in range(Pref.cols)
        )
        return float(num / nrm)


def impl_bracket_calls(impl, case: dict, batched: bool) -> list[tuple[str, int, object]]:
    """``(label suffix, points, callable)`` for the implementation's ``poisson_tensor`` on a bracket
    case: one call per point, and (``batched``) one call on the whole batch."""
    f = np.array(catalogue(case["algebra"]).f, dtype=float)
    th, U, X, Pi = case["theta"], case["upsilon"], case["x"], case["pi"]
    out = [
        (
            "one call per point",
            len(X),
            lambda: [impl.poisson_tensor(f, th, U, X[i], Pi[i]) for i in range(len(X))],
        )
    ]
    if batched:
        out.append(("batch", len(X), lambda: impl.poisson_tensor(f, th, U, X, Pi)))
    return out
