"""A declared ``order`` and ``flow(..., steps=N)``: the error in ``pi`` against the judge for doubling
step counts; the fitted order must reach the declared one (within 0.5). The judge: the proven boxes
(``_common._judge_state``: float64 intervals where ``Upsilon = 0``, Arb balls otherwise; their error
proven), the float64 judge where no box is given (counted by reason)."""

from __future__ import annotations

import itertools
import math

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    C_CERT,
    conditioning,
    eps_impl,
    max_err,
)

from .._common import (
    _accepts_steps,
    _call,
    _judge_state,
)
from ..check import Check, planted
from ..models import _hamiltonians


def _flow_order(impl, dom, stats):
    order = float(impl.order)

    def body(ex):
        (((_name, f, theta, ups, x, pi), inertia, pot),) = ex
        n = f.shape[0]
        if np.linalg.norm(pi) < 0.5:
            reject()  # a state at rest says nothing about order or drift
        t = min(1.0, dom.max_abs_t or 1.0)
        cond, _ = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond > 1e4:
            return None
        try:
            (_jx, jp, _jA), jerr = _judge_state(f, theta, ups, inertia, pot, x, pi, t, stats)
        except (ArithmeticError, np.linalg.LinAlgError):
            reject()
        scale = max(1.0, float(np.max(np.abs(jp))))
        floor = max(
            1e3 * C_CERT * n * eps_impl(impl) * cond * scale, 100 * max(e or 0.0 for e in jerr)
        )
        errs = []
        for N in (1, 2, 4, 8, 16, 32, 64, 128):
            try:
                _gx, gp = _call(impl, "flow", f, theta, ups, inertia, pot, x, pi, t, steps=N)
            except (ValueError, ArithmeticError):
                # a refusal, or a coarse step count that overflows (FloatingPointError where the
                # caller's numpy raises on overflow): outside the asymptotic regime, like an inf
                continue
            gp = np.asarray(gp, dtype=float)
            e = max_err(gp, jp)
            errs.append((N, e))
            if e < floor:
                break
        fits = [
            math.log2(e1 / e2)
            for (n1, e1), (n2, e2) in itertools.pairwise(errs)
            if n2 == 2 * n1 and floor < e2 < e1 < 0.1 * scale
        ]
        if not fits:
            stats["redrawn: no step range in the asymptotic regime"] = (
                stats.get("redrawn: no step range in the asymptotic regime", 0) + 1
            )
            reject()
        observed = max(fits[-2:]) if len(fits) > 1 else fits[-1]
        stats["observed order"] = min(stats.get("observed order", math.inf), round(observed, 2))
        # the fitted order must reach the declared one within 0.5 (ratio 1 at order - 0.5)
        return max(0.0, (order - observed) / 0.5), None

    return body, st.tuples(_hamiltonians("generic", dom))


def _applies(impl, dom):
    if getattr(impl, "order", None) is None:
        return "the implementation declares no order"
    if not _accepts_steps(impl):
        return "flow does not accept steps= (needed to measure the order)"
    return None


CHECK = Check(
    id="flow.order",
    needs=("flow",),
    equations="(integrator order)",
    build=_flow_order,
    order=90,
    # the full k examples (15 under ci): measured on the plain RK4 (tstarg.reports.mutants:Plain),
    # seed 0, load 7: 15 examples in 3.3 s CPU, the boxes 0.014 s per example (median; max 0.26 s)
    applies=_applies,
    extra=lambda impl: {"declared order": getattr(impl, "order", None)},
    mutants=planted("order_overclaimed"),
)
