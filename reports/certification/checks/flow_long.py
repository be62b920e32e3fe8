"""``flow.long``: the state at times spread over ``[-T, T]`` (``T = min(FLOW_T_MAX, declared
max_abs_t)``, 10 by default) vs the independent float64 judge
(:class:`tstarg.oracles.float_judge.FloatJudge`: DOP853 at rtol 1e-13, its error estimated by a
second run at rtol 1e-12 and stated in the certificate), with the tolerance ``flow_tolerance`` times
the flow's condition ``||D Phi||`` (estimated by the judge from a perturbed start,
:func:`tstarg.oracles.float_judge.sensitivity_at`: a backward-stable integrator errs by that much), on
the group the flow lives on
(:mod:`..group`): compared through ``rho(g)`` (chart-free, faithful: it sees the SU(2) sheet and
the centre), ``Ad(g)``, ``pi``, and ``x`` while it stays inside ``||ad_x|| < pi``.

Each example is judged at two times from one judge integration: a drawn fraction of the example's
reach and the reach itself, ``T_ex = min(T, LONG_WORK_LIMIT / rate)`` (``rate``: the model's
fastest rate at the start, :func:`reference_work` per unit time), so every example that can reach
the certified ``|t|`` is judged there; both signs of ``t``. One draw in three is su(2) (when the
domain admits it) with momenta ``|pi| in [1.5, 4]``: rigid bodies and heavy tops whose ``x(t)``
passes ``|x| = pi`` (counted in the certificate)."""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from tstarg.oracles.float_judge import ad, conditioning, flow_tol, reference_work
from tstarg.refimpl import catalogue, su2
from tstarg.refimpl.fast import implementation as fast

from .._common import (
    FLOW_T_MAX,
    INTERVAL_JUDGE,
    LONG_WORK_LIMIT,
    _aim,
    _count,
    _finite_array,
    _flow_call,
    _judge_on,
    _judged_state_ratio,
    _proven_on,
    _time_ok,
)
from ..check import Check, Mutant, planted
from ..domain import Domain
from ..group import declared_group, group_for
from ..models import Hamiltonian, _hamiltonians


def _su2_tops(dom: Domain):
    """su(2) models (inside ``dom``) with ``|pi|`` scaled into [1.5, 4]: fast enough to carry
    ``x(t)`` past ``|x| = pi`` within ``|t| <= 10``."""
    within = Domain(
        algebras=("su(2)",),
        theta=dom.theta,
        upsilon=dom.upsilon,
        gravity=dom.gravity,
        declared=True,
    )

    def spin(h, size):
        (name, f, theta, ups, x, pi), inertia, pot = h
        norm = float(np.linalg.norm(pi))
        pi = pi * (size / norm) if norm > 0 else np.array([0.0, 0.0, size])
        return Hamiltonian((name, f, theta, ups, x, pi), inertia, pot)

    return st.builds(spin, _hamiltonians("generic", within), st.floats(1.5, 4.0))


def _flow_long(impl, dom, stats):
    T = min(FLOW_T_MAX, dom.max_abs_t or math.inf)
    spec = declared_group(impl)
    stats["judge"] = (
        f"{INTERVAL_JUDGE}: proven boxes of pi, Ad(g), rho(g) and x at both times from one run (their "
        "radius plus half an ulp, the judge error, is added twice to every tolerance; the flow's "
        "condition from a second run from a moved start); where no box is given (counted by reason), "
        "the float64 judge (DOP853, its error estimated)"
    )

    def body(ex):
        ((_name, f, theta, ups, x, pi), inertia, pot), frac, sign = ex
        n = f.shape[0]
        if not _time_ok(dom, sign):
            reject()
        cond, frame = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond > 1e6:
            return None
        # bounded work for the judge and the implementation: |t| rate <= LONG_WORK_LIMIT
        rate = reference_work(f, theta, ups, inertia, pot, x, pi, 1.0) / n**3
        reach = min(T, LONG_WORK_LIMIT / rate)
        if reach < 0.05 * T:
            _count(stats, "redrawn: over the work limit")
            reject()
        times = sorted({sign * max(frac * reach, 1e-3), sign * reach}, key=abs)
        group = group_for(spec, f)
        proven = _proven_on(group, f, theta, ups, inertia, pot, x, pi, times)
        if isinstance(proven, tuple):
            states, Gs, errs, sens, judge = proven
            _count(stats, f"examples judged by {judge}")
        else:  # no box (counted by reason): the float64 judge, its error estimated
            judge = None
            _count(stats, f"examples judged by the float64 judge (no box: {proven})")
            try:
                states, Gs, errs, sens = _judge_on(group, f, theta, ups, inertia, pot, x, pi, times)
            except (ArithmeticError, np.linalg.LinAlgError):
                _count(stats, "redrawn: judge failed")
                reject()
        worst = 0.0
        for t, (jx, jp, jA), G, jerr, kappa in zip(times, states, Gs, errs, sens):
            scale = max(
                1.0, float(np.max(np.abs(jp))), float(np.max(np.abs(jx))) if jx is not None else 1.0
            )
            # a backward-stable integrator errs by its tolerance times the flow's condition kappa
            tol = flow_tol(impl, n, cond, frame) * scale * kappa
            stats["flow condition (estimated, largest)"] = max(
                stats.get("flow condition (estimated, largest)", 1.0), float(f"{kappa:.3g}")
            )
            judge_err = max(e or 0.0 for e in jerr)
            if judge_err > 0.1 * tol:
                _count(stats, "redrawn: judge not accurate enough")
                reject()
            key = "judge error (estimated, worst) / tolerance"
            if judge is not None:  # the boxes' radius plus half an ulp: a proven bound
                key = "judge error (proven, worst) / tolerance"
            stats[key] = max(stats.get(key, 0.0), float(f"{judge_err / tol:.3g}"))
            out = _flow_call(impl, dom, stats, (f, theta, ups, inertia, pot, x, pi), t)
            if out is None:
                return None
            got = _finite_array(out[0], (n,), "x(t)"), _finite_array(out[1], (n,), "pi(t)")
            if judge is not None and jx is not None and np.linalg.norm(ad(f, got[0]), 2) >= np.pi:
                # the boxes' x is the principal logarithm; a flow that carries x on past the chart
                # without re-basing (e.g. x = 1.5 t e_3 on su(2)) is judged through rho(g) and Ad(g),
                # chart-free, as the float64 judge does once its own x reaches the chart's edge
                jx = None
            ratio = _judged_state_ratio(impl, f, t, got, (jx, jp, jA), tol, jerr, G, group)
            worst = max(worst, ratio)
            if t < 0:
                _count(stats, "negative t judged")
            if abs(t) >= 0.9 * T:
                _count(stats, f"judged at |t| >= 0.9 T (T = {T:g})")
            stats["largest |t| judged"] = max(
                stats.get("largest |t| judged", 0.0), round(abs(t), 2)
            )
            if n == 3 and np.array_equal(f, su2().f) and np.linalg.norm(got[0]) > np.pi:
                _count(stats, "su(2): |x(t)| > pi judged")
        _aim(worst, "long flow ratio")
        return worst, None

    general = _hamiltonians("generic", dom)
    models = st.one_of(general, general, _su2_tops(dom)) if dom.admits(su2().f) else general
    return body, st.builds(
        FlowLongExample, models, st.floats(0.05, 1.0), st.sampled_from([1.0, -1.0])
    )


FlowLongExample = namedtuple("FlowLongExample", "hamiltonian fraction_of_reach sign_of_t")
"""One example of ``flow.long``: judged at ``t = sign reach fraction`` and ``t = sign reach``."""


def _sentinels(impl, dom) -> list:
    """The cases ``flow.long`` judges first under every seed (each only where ``dom`` admits it):
    an asymmetric su(2) top with a non-diagonal inertia whose ``x(t)`` passes ``|x| = pi`` and whose
    reach is the certified ``|t|`` (both signs), and a body on h(3), whose centre a flow that
    re-bases through ``Ad(g)`` alone loses (judged through ``rho(g)``) once ``|t| >= 1``."""
    z3 = np.zeros((3, 3))
    inertia = np.array([[1.0, 0.1, 0.0], [0.1, 1.3, 0.05], [0.0, 0.05, 0.6]])
    cases = [
        (su2().f, np.array([0.1, 0.2, 0.0]), np.array([0.8, -0.6, 2.0]), 0.5, 1.0),
        (su2().f, np.array([0.0, 0.3, 0.1]), np.array([-0.5, 0.9, 1.8]), 0.3, -1.0),
        (catalogue("h(3)").f, np.array([0.1, 0.2, 0.3]), np.array([0.5, -0.3, 0.8]), 0.5, 1.0),
    ]
    out = []
    for f, x, pi, frac, sign in cases:
        if dom.admits(f) and _time_ok(dom, sign):
            model = ("sentinel", np.array(f, dtype=float), z3, z3, x, pi)
            out.append(FlowLongExample(Hamiltonian(model, inertia, None), frac, sign))
    return out


# ------------------------------------------------------------------ planted mutants
def _so3_log(f, x):
    """su(2)'s x mapped to SO(3)'s principal logarithm (|x| <= pi): the same rotation Ad(g), the
    other SU(2) sheet past |x| = pi."""
    x = np.asarray(x, dtype=float)
    r = float(np.linalg.norm(x))
    if f.shape == (3, 3, 3) and np.array_equal(np.asarray(f, dtype=float), su2().f) and r > np.pi:
        return x * (1.0 - 2.0 * np.pi / r)
    return x


class SO3Flow:
    """A correct flow that lives on SO(3) for su(2): it returns ``x = log_SO(3)(R)``, ``|x| <= pi``.
    ``declare=True`` says so (``group = "SO(3)"``) and must pass; undeclared it must be rejected."""

    version = "test"
    flow_tolerance = 1e-10  # refimpl.fast's

    def __init__(self, declare: bool):
        self.name = "SO(3) flow" + (" (declared)" if declare else " (undeclared)")
        if declare:
            self.group = "SO(3)"

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):

        x, p = fast.flow(f, theta, upsilon, inertia, potential, x0, pi0, t)
        return _so3_log(np.asarray(f, dtype=float), x), p


class LooseAfter:
    """A flow accurate to ``|t| = 5`` (refimpl.fast's) and loose beyond: ``pi`` off by 1e-6
    relative past ``|t| = 5`` (it declares ``flow_tolerance = 1e-10`` throughout)."""

    name, version = "loose past |t| = 5", "test"
    flow_tolerance = 1e-10  # refimpl.fast's

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):

        x, p = fast.flow(f, theta, upsilon, inertia, potential, x0, pi0, t)
        if abs(t) > 5:
            p = np.asarray(p, dtype=float) * (1 + 1e-6)
        return x, p


CHECK = Check(
    id="flow.long",
    needs=("flow",),
    equations="vier10, vier11, twee16",
    build=_flow_long,
    order=65,
    sentinels=_sentinels,
    mutants={
        **planted("flow_fixed_steps", "centre_lost"),
        "so3_undeclared": Mutant(
            "a correct flow on SO(3) for su(2) (x = log_SO(3), |x| <= pi) that does not declare "
            "group = 'SO(3)'",
            lambda: SO3Flow(False),
        ),
        "loose_after_5": Mutant(
            "a flow accurate to |t| = 5 and off by 1e-6 beyond (declared flow_tolerance 1e-10)",
            LooseAfter,
        ),
    },
)
