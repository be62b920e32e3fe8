"""Flows of ``H = K(pi) + V(g)`` under omega_L: reference trajectories, fast integrators, invariants.

Public face of :mod:`refimpl._flow_reference` (mpmath, any precision),
:mod:`refimpl._flow_fast` (numpy, batched) and :mod:`refimpl._integrators`.

Protocol method 3 (DESIGN.md), with the signature
``flow(f, theta, upsilon, inertia, potential, x0, pi0, t) -> (x, pi)``:

* :func:`reference_flow` (``dps=50``): the full state of vier10/vier11 by
  Gragg-Bulirsch-Stoer extrapolation at ``dps + 15`` digits, re-basing
  ``g = g_ref exp(x)`` on long flows;
* :func:`fast_flow`: float64, batched over the leading axes of ``x0``, ``pi0``;
  the number of steps is doubled until two runs agree to ``tol`` on every
  trajectory (worst trajectory, not an average).

Body systems only (no configuration; ``integrate_fast(..., system="body")``
or ``fast_trajectory(..., system="body")``): ``dop853-scalar`` and the
Taylor-series methods ``taylor12/16/20/24`` (:mod:`refimpl._taylor`: Cauchy-
product recurrences for the quadratic field of ``Upsilon = 0``): the fastest
fixed-step methods here for one trajectory; for batches on par with the batched
``dop853`` on an asymmetric top and several times faster when a component is
constant (a symmetric top's ``pi_3``), see tests/benchmarks/test_bench_flows.py.

Scenes (:func:`load_scene`, :func:`plan`, :func:`run_scene`): see :mod:`refimpl._scenes`.

Invariants (:func:`energy`, :func:`casimirs`, :func:`momentum_map`):

* energy ``H = 1/2 pi.I^-1 pi - Gamma.L`` (twee10, twee15);
* Casimirs of the reduced Lie-Poisson brackets: for su(2) ``|pi'|^2`` with
  ``pi' = pi + xi`` (drie7; Upsilon = 0); for Euler-Poisson on so(3)/su(2)
  ``|Gamma|^2`` and ``pi'.Gamma``;
* the momentum map of the left action ``h.(g, pi) = (hg, pi)`` when ``V = 0``.
  Its generator is the right-invariant field ``X_zeta(g) = zeta g``, with body
  components ``Ad(g^-1) zeta`` and no ``pi`` component, so ``Upsilon`` does not
  enter. ``i_X omega_0 = d(pi.Ad(g^-1) zeta)`` since ``omega_0 = -d(pi eps_L)``
  and ``L_X (pi eps_L) = 0``. The closed left-invariant form ``Theta_L`` gives
  ``i_X Theta_L = d phi_zeta``; integrating along ``s -> exp(s x)``, where
  ``eps_L = x ds`` and ``Ad(exp(-s x)) = exp(-s ad_x)``,
  ``phi_zeta(x) = int_0^1 Theta(exp(-s ad_x) zeta, x) ds = Theta(A zeta, x)``
  with ``A = phi1(-ad_x)``. Hence, for ``omega_I = omega_0 - Theta_L`` (drie1),
  ``J(g, pi) = K(g) pi - A(x)^T Theta x`` with ``K(g) = Ad(g^-1)^T`` (twee3);
  across re-basings the path integral adds ``K(g_ref) A(x)^T Theta x`` per
  segment. For a coboundary ``Theta = -xi.f`` (zeven3),
  ``ad_x A = 1 - e^-ad_x`` gives ``A^T Theta x = xi - K(g) xi``, so
  ``J = K(g)(pi + xi) - xi``: the Darboux momentum ``pi'`` of drie7 transported,
  minus a constant (the non-equivariance cocycle).
"""

from __future__ import annotations

import mpmath
import numpy as np

from . import fast as _fast
from ._flow_fast import METHODS, Method, NumpyModel, integrate_fast, method, qmul, quat_to_x, x_to_quat
from ._flow_reference import (
    ModelMP, ReferenceTrajectory, check_time, euler_top_closed_form, reference_flow, reference_trajectory,
)
from ._integrators import DOP853, RK4, ExplicitRK, GaussLegendre, gbs_mp, triple_jump_weights
from ._validate import check_points

from ._scenes import OUTPUTS, Plan, Scene, load_scene, parse_scene, plan, run_scene  # noqa: E402

__all__ = [
    "reference_flow", "reference_trajectory", "ReferenceTrajectory", "euler_top_closed_form", "ModelMP",
    "fast_flow", "fast_trajectory", "NumpyModel", "METHODS", "Method", "method", "integrate_fast",
    "energy", "casimirs", "momentum_map", "check_tolerance", "check_time",
    "DOP853", "RK4", "ExplicitRK", "GaussLegendre", "gbs_mp", "triple_jump_weights",
    "qmul", "quat_to_x", "x_to_quat",
    "Scene", "Plan", "load_scene", "parse_scene", "plan", "run_scene", "OUTPUTS",
]


def check_tolerance(tol) -> float:
    try:
        v = float(tol)
    except (TypeError, ValueError):
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}")
    return v


def _default_method(model: NumpyModel) -> Method:
    return METHODS["dop853"] if model.upsilon_zero else METHODS["gauss6"]


def fast_flow(f, theta, upsilon, inertia, potential, x0, pi0, t, *, method_name: str | None = None,
              steps: int | None = None, tol: float = 1e-10):
    """Protocol method 3, batched: ``(x, pi)`` at time ``t`` for every initial point.

    ``method_name``: a key of :data:`METHODS` (default: ``dop853``, or
    ``gauss6`` when ``Upsilon != 0``). ``steps``: a fixed step count; by
    default steps are doubled from ``8 + 4 t`` until the runs with ``N`` and
    ``2N`` steps differ by at most ``tol * (2^p - 1)`` (Richardson: the
    error of the finer run is then below ``tol``) on every trajectory.
    Raises ``ValueError`` for bad ``t``/``tol``, starting points on the
    degenerate set (naming them), or an end point outside the chart.
    """
    tv = check_time(t)
    tol = check_tolerance(tol)
    model = NumpyModel(f, theta, upsilon, inertia, potential)
    n = model.n
    xa, pa = check_points(x0, pi0, n, batched=True)
    shape = xa.shape[:-1]
    X = np.ascontiguousarray(xa.reshape(-1, n).T)
    P = np.ascontiguousarray(pa.reshape(-1, n).T)
    _check_start(model, P)
    meth = METHODS[method_name] if method_name is not None else _default_method(model)
    if method_name is not None:
        method(method_name)
    if tv == 0:
        return xa.copy(), pa.copy()
    if steps is not None:
        if not isinstance(steps, (int, np.integer)) or steps < 1:
            raise ValueError(f"steps must be a positive int, got {steps!r}")
        out = integrate_fast(model, meth, X, P, tv, int(steps), system="full")
    else:
        N = int(8 + 4 * np.ceil(tv))
        prev = integrate_fast(model, meth, X, P, tv, N, system="full")
        for _ in range(14):
            N *= 2
            out = integrate_fast(model, meth, X, P, tv, N, system="full")
            diff = np.max(np.abs(np.concatenate([out["pi"] - prev["pi"], _xdiff(out, prev)])), axis=0)
            if np.all(diff <= tol * (2 ** meth.order - 1)):
                break
            prev = out
        else:
            raise ValueError(f"fast_flow: tolerance {tol} not reached with {N} steps")
    bad_pi = ~np.all(np.isfinite(out["pi"]), axis=0)
    if np.any(bad_pi):
        raise ValueError(
            f"fast_flow: trajectories {np.flatnonzero(bad_pi)[:10].tolist()} became non-finite before t = {tv} "
            "(they reached the degenerate set Pi_1, vier12, or diverged); no point is dropped")
    x = out["x"]
    if np.any(~np.isfinite(x)):
        bad = np.argwhere(~np.all(np.isfinite(x), axis=0)).ravel()
        raise ValueError(
            f"fast_flow: the configuration of trajectories {bad[:10].tolist()} left the chart of exponential "
            "coordinates and no representation is available to re-express g(t) = exp(x); use "
            "fast_trajectory for the group element")
    return x.T.reshape(shape + (n,)), out["pi"].T.reshape(shape + (n,))


def _xdiff(a, b):
    if a.get("Ad") is not None:
        return (a["Ad"] - b["Ad"]).reshape(a["Ad"].shape[0], -1).T
    return a["x"] - b["x"]


def _check_start(model: NumpyModel, P: np.ndarray) -> None:
    """Starting points on the degenerate set (``Delta = 0`` to float64 accuracy, vier12) are refused."""
    if model.upsilon_zero:
        return
    res = _fast.Fast().poisson_batch(model.f, model.theta, model.upsilon, np.zeros_like(P.T), P.T)
    if np.any(res.degenerate):
        idx = np.argwhere(res.degenerate).ravel()
        raise ValueError(
            f"initial point(s) {idx[:10].tolist()} lie on the degenerate set Pi_1 (Delta = det Phi = 0 to float64 "
            f"accuracy, vier12): no flow exists there")


def fast_trajectory(f, theta, upsilon, inertia, potential, x0, pi0, t_end, samples: int, steps_per_sample: int,
                    *, method_name=None, system: str = "full", progress=None):
    """A batch ``(N, n)`` sampled at ``samples`` equally spaced times in ``[0, t_end]``.

    Returns a dict: ``times`` (T,), ``pi`` (T, N, n), ``Gamma`` (T, N, n) or
    None, ``x`` (T, N, n) (NaN outside the chart when no representation is
    known) or None for ``system="body"``, and the method used.
    """
    tv = check_time(t_end, "t_end")
    if tv == 0:
        raise ValueError("t_end must be > 0 for a trajectory")
    if samples < 2 or steps_per_sample < 1:
        raise ValueError(f"samples must be >= 2 and steps_per_sample >= 1, got {samples}, {steps_per_sample}")
    model = NumpyModel(f, theta, upsilon, inertia, potential)
    n = model.n
    xa, pa = check_points(x0, pi0, n, batched=True)
    X = np.ascontiguousarray(np.atleast_2d(xa).reshape(-1, n).T)
    P = np.ascontiguousarray(np.atleast_2d(pa).reshape(-1, n).T)
    _check_start(model, P)
    meth = METHODS[method_name] if method_name else _default_method(model)
    nsteps = (samples - 1) * steps_per_sample
    rec = {"pi": [], "Gamma": [], "x": []}

    def observe(k, pi, G, x):
        if k % steps_per_sample == 0:
            rec["pi"].append(pi.T.copy())
            if G is not None:
                rec["Gamma"].append(G.T.copy())
            if x is not None:
                rec["x"].append(np.asarray(x).T.copy())
            if progress is not None:
                progress(k // steps_per_sample, samples - 1)

    G0 = None
    if model.gravity:
        adx = np.einsum("aN,mab->Nmb", X, model.f)
        G0 = np.einsum("Nmb,m->bN", _fast._expm_batch(adx, su2=model.su2), model.gamma).T
    observe(0, P, None if G0 is None else G0.T, X if system == "full" else None)
    integrate_fast(model, meth, X, P, tv, nsteps, system=system, observe=observe)
    return {"times": np.linspace(0, tv, samples), "pi": np.stack(rec["pi"]), "method": meth,
            "Gamma": np.stack(rec["Gamma"]) if rec["Gamma"] else None,
            "x": np.stack(rec["x"]) if rec["x"] else None}


# ------------------------------------------------------------ invariants
def energy(inertia, potential, pi, Gamma=None):
    """``H = 1/2 pi.I^-1 pi - Gamma.L`` per point (twee10, twee15); arrays (..., n)."""
    Iinv = np.linalg.inv(np.asarray(inertia, dtype=float))
    pi = np.asarray(pi, dtype=float)
    H = 0.5 * np.einsum("...a,ab,...b->...", pi, Iinv, pi)
    if potential is not None and Gamma is not None:
        H = H - np.asarray(Gamma, dtype=float) @ np.asarray(potential["L"], dtype=float)
    return H


def casimirs(f, theta, pi, Gamma=None):
    """Casimirs of the reduced bracket for su(2)/so(3) with Upsilon = 0 (dict name -> array).

    ``|pi'|^2`` (V = 0) with ``pi' = pi + xi``; with gravity ``|Gamma|^2`` and
    ``pi'.Gamma`` (Euler-Poisson; for ``xi != 0`` the coupling term is
    ``pi'.Gamma`` because ``pi'`` obeys the untwisted equations, drie12).
    """
    f = np.asarray(f, dtype=float)
    if not _fast._is_su2(f):
        raise ValueError("casimirs: written for su(2)/so(3) (f = epsilon)")
    xi = _fast._su2_theta_to_xi(np.asarray(theta, dtype=float))
    q = np.asarray(pi, dtype=float) + xi
    if Gamma is None:
        return {"|pi'|^2": np.sum(q * q, axis=-1)}
    G = np.asarray(Gamma, dtype=float)
    return {"|Gamma|^2": np.sum(G * G, axis=-1), "pi'.Gamma": np.sum(q * G, axis=-1)}


def momentum_map(f, theta, x, pi, *, dps: int | None = None):
    """``J = K(g) pi - A(x)^T Theta x`` for ``g = exp(x)`` (module docstring); conserved when V = 0.

    ``dps=None``: float64 (one point, arrays (n,)); ``dps=int``: mpmath at that precision.
    """
    if dps is None:
        from ._frames import frames

        fr = frames(f, np.asarray(x, dtype=float))
        th = np.asarray(theta, dtype=float)
        x = np.asarray(x, dtype=float)
        return fr["K"] @ np.asarray(pi, dtype=float) - fr["A"].T @ (th @ x)
    with mpmath.workdps(dps):
        model = ModelMP(f, theta, np.zeros_like(np.asarray(theta, dtype=object)), np.eye(len(np.asarray(x))), None)
        xv = mpmath.matrix([mpmath.mpf(v) if not isinstance(v, str) else mpmath.mpf(v) for v in x])
        pv = mpmath.matrix([mpmath.mpf(v) for v in pi])
        K = mpmath.expm(-model.ad(xv)).T
        return K * pv - model.cocycle_term(xv)
