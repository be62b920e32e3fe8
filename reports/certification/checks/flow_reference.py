"""The state at ``|t| <= 1`` vs the mpmath reference flow, gravity and non-diagonal inertia included;
negative times by the round trip ``flow(flow_ref(z0, |t|), -|t|) = z0``. Each example's reference
cost is estimated first (:func:`reference_work`); examples over :data:`REFERENCE_WORK_LIMIT` are
drawn again (counted in the certificate, never integrated), and reference results are cached across
shrink steps, and on disk (``$TSTARG_CACHE_DIR/reference-flows``): a re-certification reuses them.
The budget is the full ``k`` examples per run (15 under the ci profile)."""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
import scipy.linalg
from hypothesis import reject
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    ad,
    conditioning,
    flow_tol,
    max_err,
    reference_work,
)

from .._common import (
    FLOW_REF_T_MAX,
    REFERENCE_DPS,
    REFERENCE_WORK_LIMIT,
    _aim,
    _count,
    _digits,
    _finite_array,
    _flow_call,
    _judged_state_ratio,
    _reference_state,
    _time_ok,
)
from ..check import Check, planted
from ..group import declared_group, group_for
from ..models import _hamiltonians


def _flow_reference(impl, dom, stats):
    spec = declared_group(impl)

    def body(ex):
        ((_name, f, theta, ups, x, pi), inertia, pot), t = ex
        n = f.shape[0]
        if not _time_ok(dom, t):
            reject()
        cond, frame = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond > 1e6:
            return None
        work = reference_work(f, theta, ups, inertia, pot, x, pi, t)
        if work > REFERENCE_WORK_LIMIT:
            stats["redrawn: reference over the work limit"] = (
                stats.get("redrawn: reference over the work limit", 0) + 1
            )
            reject()
        stats["max reference work"] = max(stats.get("max reference work", 0.0), round(work, 1))

        refd = _reference_state(f, theta, ups, inertia, pot, x, pi, abs(t))
        stats["judge"] = (
            f"refimpl.reference's flow at {REFERENCE_DPS} digits (its error ~1e-{REFERENCE_DPS - 5}, "
            "far below every float64 tolerance), cached on disk"
        )
        if refd is None:
            stats["redrawn: reference unavailable (chart)"] = (
                stats.get("redrawn: reference unavailable (chart)", 0) + 1
            )
            reject()
        xr, pr = (np.asarray(v, dtype=float) for v in refd)
        # both directions from one reference run (the reference dominates the cost): forward from
        # the drawn start to the reference end point, and back (time -|t|) from that end point to
        # the drawn start; a flow that mishandles negative times fails every example
        legs = [(abs(t), (x, pi), (xr, pr))]
        if _time_ok(dom, -abs(t)):
            legs.append((-abs(t), (xr, pr), (x, pi)))
        c2, f2 = conditioning(f, theta, ups, xr, pr)
        cond, frame = max(cond, c2), max(frame, f2)
        worst, worst_digits = 0.0, math.inf
        for tt, start, want in legs:
            out = _flow_call(
                impl, dom, stats, (f, theta, ups, inertia, pot, start[0], start[1]), tt
            )
            if out is None:
                return None
            gx = _finite_array(out[0], (n,), f"x(t) at t = {tt:g}")
            gp = _finite_array(out[1], (n,), f"pi(t) at t = {tt:g}")
            scale = max(1.0, float(np.max(np.abs(np.concatenate(want)))))
            tol = flow_tol(impl, n, cond, frame) * scale
            group = group_for(spec, f)
            try:
                ratio = _judged_state_ratio(
                    impl,
                    f,
                    tt,
                    (gx, gp),
                    (want[0], want[1], scipy.linalg.expm(ad(f, want[0]))),
                    tol,
                    (0.0, 0.0, 0.0, 0.0),
                    None if group is None else group.exp(want[0]),
                    group,
                )
            except AssertionError:
                if tt < 0:
                    _count(stats, "failed backwards (t < 0, from the reference end point)")
                raise
            err = max_err(np.concatenate([gx, gp]), np.concatenate(want))
            if tt < 0:
                _count(stats, "negative t judged")
            worst = max(worst, ratio)
            worst_digits = min(worst_digits, _digits(err, scale))
        _aim(worst, "flow ratio")
        return worst, worst_digits

    times = st.sampled_from([0.1, 0.5, FLOW_REF_T_MAX])
    return body, st.builds(FlowReferenceExample, _hamiltonians("generic", dom), times)


FlowReferenceExample = namedtuple("FlowReferenceExample", "hamiltonian t")
"""One example of ``flow.reference``: forward to ``|t|``, and back from the reference end point."""


CHECK = Check(
    id="flow.reference",
    needs=("flow",),
    equations="vier10, vier11",
    build=_flow_reference,
    order=70,
    mutants=planted("flow_wrong_stage", "flow_abs_time"),
)
