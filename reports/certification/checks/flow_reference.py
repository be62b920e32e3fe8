"""The state at ``|t| <= 1`` vs the proven boxes of the whole state (``_common._proven_state``:
float64 intervals where ``Upsilon = 0``, Arb balls at 64 bits otherwise; x by a proven principal
logarithm), gravity and non-diagonal inertia included; negative
times from the judge's end point back, against the balls of the backward flow from there. Where the
balls refuse (counted by reason in the certificate) the mpmath reference judges, with negative
times by the round trip ``flow(flow_ref(z0, |t|), -|t|) = z0``. Each example's reference
cost is estimated first (:func:`reference_work`); examples over :data:`REFERENCE_WORK_LIMIT` are
drawn again (counted in the certificate, never integrated), and reference results are cached across
shrink steps, and on disk (``$TSTARG_CACHE_DIR/reference-flows``): a re-certification reuses them.
The budget is the full ``k`` examples per run (15 under the ci profile)."""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    ad,
    conditioning,
    expm,
    flow_tol,
    max_err,
    reference_work,
)

from .._common import (
    FLOW_REF_T_MAX,
    PROVEN_JUDGE,
    REFERENCE_DPS,
    REFERENCE_WORK_LIMIT,
    _aim,
    _count,
    _digits,
    _finite_array,
    _flow_call,
    _judge_errors,
    _judged_state_ratio,
    _proven_state,
    _reference_state,
    _time_ok,
)
from ..check import Check, planted
from ..group import declared_group, group_for
from ..models import _hamiltonians


def _flow_reference(impl, dom, stats):
    spec = declared_group(impl)
    stats["judge"] = (
        f"{PROVEN_JUDGE}: proven balls of the whole state (their radius plus half an ulp, the "
        "judge_error, is added twice to every tolerance); where the balls refuse, refimpl.reference's "
        f"flow at {REFERENCE_DPS} digits (its error ~1e-{REFERENCE_DPS - 5}, far below every float64 "
        "tolerance), cached on disk"
    )

    def reference(ex_args, t):
        f, theta, ups, inertia, pot, x, pi = ex_args
        work = reference_work(f, theta, ups, inertia, pot, x, pi, t)
        if work > REFERENCE_WORK_LIMIT:
            _count(stats, "redrawn: reference over the work limit")
            reject()
        stats["max reference work"] = max(stats.get("max reference work", 0.0), round(work, 1))
        refd = _reference_state(f, theta, ups, inertia, pot, x, pi, t)
        if refd is None:
            _count(stats, "redrawn: reference unavailable (chart)")
            reject()
        return tuple(np.asarray(v, dtype=float) for v in refd)

    def body(ex):
        ((_name, f, theta, ups, x, pi), inertia, pot), t = ex
        n = f.shape[0]
        if not _time_ok(dom, t):
            reject()
        cond, frame = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond > 1e6:
            return None
        model = (f, theta, ups, inertia, pot)
        ta = abs(t)
        proven = _proven_state(*model, x, pi, ta)
        if isinstance(proven, tuple):
            xr, pr, ex_, ep_, name = proven
            _count(stats, f"forward legs judged by {name}")
        else:  # the balls refuse (named): the mpmath reference judges, unproven
            _count(stats, f"balls refused: {proven}")
            xr, pr = reference((*model, x, pi), ta)
            ex_ = ep_ = 0.0
            _count(stats, "forward legs judged by the mpmath reference (the balls refused)")
        # forward from the drawn start to the judge's end point, and back (time -|t|) from that end
        # point: to the drawn start (the mpmath route: the round trip, the reference error carried
        # back unamplified is far below tolerance), or, where the balls enclose the backward flow from
        # that float64 start, to their proven balls; a flow that mishandles negative times fails
        legs = [(ta, (x, pi), (xr, pr), (ex_, ep_))]
        if _time_ok(dom, -ta):
            back = _proven_state(*model, xr, pr, -ta) if isinstance(proven, tuple) else None
            if isinstance(back, tuple):
                legs.append((-ta, (xr, pr), back[:2], back[2:4]))
            else:
                if back is not None:
                    _count(stats, f"backward legs by the round trip (balls refused: {back})")
                legs.append((-ta, (xr, pr), (x, pi), (0.0, 0.0)))
        c2, f2 = conditioning(f, theta, ups, xr, pr)
        cond, frame = max(cond, c2), max(frame, f2)
        worst, worst_digits = 0.0, math.inf
        group = group_for(spec, f)
        for tt, start, want, (jx, jp) in legs:
            out = _flow_call(impl, dom, stats, (*model, start[0], start[1]), tt)
            if out is None:
                return None
            gx = _finite_array(out[0], (n,), f"x(t) at t = {tt:g}")
            gp = _finite_array(out[1], (n,), f"pi(t) at t = {tt:g}")
            scale = max(1.0, float(np.max(np.abs(np.concatenate(want)))))
            tol = flow_tol(impl, n, cond, frame) * scale
            if jx or jp:
                stats["judge_error"] = max(stats.get("judge_error", 0.0), jx, jp)
            try:
                ratio = _judged_state_ratio(
                    impl,
                    f,
                    tt,
                    (gx, gp),
                    (want[0], want[1], expm(ad(f, want[0]))),
                    tol,
                    _judge_errors(f, want[0], jx, jp, group),
                    None if group is None else group.exp(want[0]),
                    group,
                )
            except AssertionError:
                if tt < 0:
                    _count(stats, "failed backwards (t < 0, from the judge's end point)")
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
