"""Implementations declaring ``order`` or ``poisson_integrator``: energy (and, where known, Casimir)
drift over long times at most Brouwer's law ``C tol sqrt(t)`` for the accuracy ``tol`` the
implementation promises (bounded, ``C tol``, for a declared Poisson integrator)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    C_CERT,
    FloatJudge,
    ad,
    conditioning,
    expm,
    flow_tol,
    meets_degenerate_set,
    reference_work,
)
from tstarg.refimpl import PROTOCOL, su2

from .._common import (
    DRIFT_T,
    DRIFT_WORK_LIMIT,
    _count,
    _finite_array,
    _flow_call,
)
from ..check import Check, planted
from ..models import _hamiltonians


def _flow_drift(impl, dom, stats):
    T_max = min(DRIFT_T, dom.max_abs_t or math.inf)
    poisson = bool(PROTOCOL.declared(impl, "poisson_integrator"))

    def body(ex):
        (((_name, f, theta, ups, x, pi), inertia, pot),) = ex
        n = f.shape[0]
        if np.linalg.norm(pi) < 0.5:
            reject()  # a state at rest says nothing about order or drift
        cond, frame = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond > 1e4:
            return None
        # long in units of the motion's own time scale: |T| (1 + rho) = LONG_WORK_LIMIT at most
        rate = reference_work(f, theta, ups, inertia, pot, x, pi, 1.0) / n**3
        T = min(T_max, DRIFT_WORK_LIMIT / rate)
        if meets_degenerate_set(f, theta, ups, inertia, pot, x, pi, T):
            _count(stats, "redrawn: the trajectory reaches the degenerate set")
            reject()  # the flow ends there: no drift law applies (and an implementation may hang)
        judge = FloatJudge(f, theta, ups, inertia, pot)
        H0 = judge.energy(pi, expm(ad(f, x)))
        Iinv = judge.Iinv
        grad = np.linalg.norm(Iinv @ pi) + (
            0
            if pot is None
            else np.linalg.norm(pot["L"]) * np.linalg.norm(pot["gamma"]) * np.linalg.norm(f)
        )
        tol = flow_tol(impl, n, cond, frame)
        casimir = (
            su2().f.shape == f.shape
            and np.array_equal(su2().f, f)
            and not np.any(ups)
            and pot is None
        )
        xi = np.array([-theta[1, 2], -theta[2, 0], -theta[0, 1]]) if casimir else None
        worst = 0.0
        for t in (T / 4, T):
            out = _flow_call(impl, dom, stats, (f, theta, ups, inertia, pot, x, pi), t)
            if out is None:
                break
            gx, gp = _finite_array(out[0], (n,), "x(t)"), _finite_array(out[1], (n,), "pi(t)")
            scale = max(1.0, float(np.max(np.abs(gp))), float(np.max(np.abs(pi))))
            growth = (
                1.0 if poisson else math.sqrt(max(1.0, t))
            )  # Brouwer: round-off walks like sqrt(t)
            dH = abs(judge.energy(gp, expm(ad(f, gx))) - H0)
            worst = max(worst, dH / (C_CERT * tol * growth * max(1.0, grad) * scale))
            if casimir:
                dC = abs(np.sum((gp + xi) ** 2) - np.sum((pi + xi) ** 2))
                worst = max(worst, dC / (C_CERT * tol * growth * 2 * scale**2))
        stats["preserved"] = "energy" + (" and |pi'|^2" if casimir else "")
        stats["longest drift time"] = max(stats.get("longest drift time", 0.0), round(T, 2))
        return worst, None

    return body, st.tuples(_hamiltonians("generic", dom))


def _applies(impl, dom):
    if getattr(impl, "order", None) is None and not PROTOCOL.declared(impl, "poisson_integrator"):
        return "a structure check for integrators: declare order or poisson_integrator = True to run it"
    return None


CHECK = Check(
    id="flow.drift",
    needs=("flow",),
    equations="twee10, twee15 (energy), drie7 (Casimir)",
    build=_flow_drift,
    order=100,
    budget=lambda k: 2,
    applies=_applies,
    extra=lambda impl: {"poisson": bool(PROTOCOL.declared(impl, "poisson_integrator"))},
    mutants=planted("energy_dissipation"),
)
