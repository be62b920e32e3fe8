"""The state at ``t`` anywhere in ``[-T, T]`` (``T = min(FLOW_T_MAX, domain max_abs_t)``) vs an
independent float64 judge (:class:`tstarg.oracles.float_judge.FloatJudge`), compared chart-free
through ``Ad(g)``, ``pi``, ``rho(g)`` on algebras with a centre, and ``x`` while it stays well
inside the chart."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    centre_representation,
    compare_state,
    conditioning,
    flow_tol,
    reference_work,
)

from .._common import (
    FLOW_T_MAX,
    LONG_WORK_LIMIT,
    _aim,
    _count,
    _finite_array,
    _flow_call,
    _judge_group,
    _time_ok,
)
from ..check import Check, planted
from ..models import _hamiltonians


def _flow_long(impl, dom, stats):
    T = min(FLOW_T_MAX, dom.max_abs_t or math.inf)

    def body(ex):
        ((_name, f, theta, ups, x, pi), inertia, pot), frac, sign = ex
        n = f.shape[0]
        t = sign * max(frac * T, 1e-3)
        if not _time_ok(dom, t):
            reject()
        cond, frame = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond > 1e6:
            return None
        # bounded work for the judge and the implementation: |t| (1 + rho) (reference_work / n^3)
        if (
            reference_work(f, theta, ups, inertia, pot, x, pi, t) / f.shape[0] ** 3
            > LONG_WORK_LIMIT
        ):
            stats["redrawn: over the work limit"] = stats.get("redrawn: over the work limit", 0) + 1
            reject()
        try:
            (jx, jp, jA), jerr, jG = _judge_group(f, theta, ups, inertia, pot, x, pi, t)
        except (ArithmeticError, np.linalg.LinAlgError):
            stats["redrawn: judge failed"] = stats.get("redrawn: judge failed", 0) + 1
            reject()
        scale = max(
            1.0, float(np.max(np.abs(jp))), float(np.max(np.abs(jx))) if jx is not None else 1.0
        )
        tol = flow_tol(impl, n, cond, frame) * scale
        if max(e or 0.0 for e in jerr) > 0.1 * tol:
            stats["redrawn: judge not accurate enough"] = (
                stats.get("redrawn: judge not accurate enough", 0) + 1
            )
            reject()
        out = _flow_call(impl, dom, stats, (f, theta, ups, inertia, pot, x, pi), t)
        if out is None:
            return None
        gx, gp = _finite_array(out[0], (n,), "x(t)"), _finite_array(out[1], (n,), "pi(t)")
        crep = None if jG is None else centre_representation(f)
        ratio = compare_state(impl, f, gx, gp, jx, jp, jA, tol, jerr, ref_G=jG, rep=crep)
        if jG is not None:
            _count(stats, "compared through a faithful representation (non-trivial centre)")
        if t < 0:
            _count(stats, "negative t judged")
        _aim(ratio, "long flow ratio")
        return ratio, None

    return body, st.tuples(
        _hamiltonians("generic", dom), st.floats(0.05, 1.0), st.sampled_from([1.0, -1.0])
    )


CHECK = Check(
    id="flow.long",
    needs=("flow",),
    equations="vier10, vier11, twee16",
    build=_flow_long,
    order=80,
    budget=lambda k: max(3, k // 3),
    mutants=planted("flow_fixed_steps", "centre_lost"),
)
