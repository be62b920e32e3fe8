"""``poisson_integrator = True`` and ``steps=``: the flow map with few fixed steps is a Poisson map,
``D Phi P D Phi^T = P o Phi`` (``D Phi`` by Richardson-extrapolated central differences, ``P`` from
the reference)."""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    ad,
    conditioning,
    max_err,
    meets_degenerate_set,
)
from tstarg.refimpl import PROTOCOL

from .._common import (
    _REF,
    _accepts_steps,
    _call,
    _digits,
)
from ..check import Check, planted
from ..models import _hamiltonians


def _flow_poisson_map(impl, dom, stats):
    def body(ex):
        ((_name, f, theta, ups, x, pi), inertia, pot), steps = ex
        n = f.shape[0]
        # t ~ one time unit of the model's fastest rate (at most 1: solvable algebras grow
        # exponentially), so that `steps` steps are coarse (h * rate ~ 1/steps): a non-Poisson method's defect (~ (h rate)^(p+1)) is then far above
        # the 1e-8 of the differences below, whatever the model's own speed
        Iinv = np.linalg.norm(np.linalg.inv(inertia), 2)
        rate = Iinv * (np.linalg.norm(pi) * np.linalg.norm(f) + np.linalg.norm(theta))
        if pot is not None:
            rate += math.sqrt(
                np.linalg.norm(f) * np.linalg.norm(pot["L"]) * np.linalg.norm(pot["gamma"]) * Iinv
            )
        if rate == 0:
            reject()  # a state at rest: every method maps it to itself
        t = min(float(np.clip(1.0 / rate, 0.25, 1.0)), dom.max_abs_t or math.inf)
        if meets_degenerate_set(f, theta, ups, inertia, pot, x, pi, t):
            reject()  # no Poisson map past Pi_1 (and the differences below start within 1e-3)
        cond, _frame = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond > 1e3:
            return None
        z0 = np.concatenate([x, pi])

        def Phi(z):
            gx, gp = _call(impl, "flow", f, theta, ups, inertia, pot, z[:n], z[n:], t, steps=steps)
            return np.concatenate([np.asarray(gx, float), np.asarray(gp, float)])

        z1 = Phi(z0)
        if np.linalg.norm(ad(f, z1[:n]), 2) > 0.5 * np.pi:
            reject()  # keep x(t) principal: D Phi in x is then the continuous one
        # central differences, Richardson-extrapolated: error O(h^4) + O(eps/h)
        h = 1e-3
        D = np.empty((2 * n, 2 * n))
        for k in range(2 * n):
            e = np.zeros(2 * n)
            e[k] = 1.0
            d1 = (Phi(z0 + h * e) - Phi(z0 - h * e)) / (2 * h)
            d2 = (Phi(z0 + 0.5 * h * e) - Phi(z0 - 0.5 * h * e)) / h
            D[:, k] = (4 * d2 - d1) / 3
        P0 = np.asarray(_REF.poisson_tensor(f, theta, ups, z0[:n], z0[n:]), dtype=float)
        P1 = np.asarray(_REF.poisson_tensor(f, theta, ups, z1[:n], z1[n:]), dtype=float)
        lhs = D @ P0 @ D.T
        scale = max(1.0, float(np.max(np.abs(P1))), float(np.max(np.abs(lhs))))
        err = max_err(lhs, P1)
        # difference error ~ 1e-11 relative (h^4 = 1e-12 times 4th derivatives, eps/h = 2e-13), times |D| |P|
        tol = 1e-8 * scale * max(1.0, float(np.max(np.abs(D)))) ** 2
        return err / tol, _digits(err, scale)

    return body, st.builds(
        PoissonMapExample, _hamiltonians("generic", dom), st.sampled_from([2, 4])
    )


PoissonMapExample = namedtuple("PoissonMapExample", "hamiltonian steps")


def _applies(impl, dom):
    if not PROTOCOL.declared(impl, "poisson_integrator"):
        return "the implementation does not declare poisson_integrator = True"
    if not _accepts_steps(impl):
        return "flow does not accept steps= (the Poisson-map test uses few fixed steps)"
    return None


CHECK = Check(
    id="flow.poisson_map",
    needs=("flow",),
    equations="vier9 (Poisson map)",
    build=_flow_poisson_map,
    order=110,
    budget=lambda k: 2,
    applies=_applies,
    mutants=planted("not_a_poisson_map"),
)
