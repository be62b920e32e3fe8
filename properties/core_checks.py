"""The core checks of ``tstarg verify`` (run by :func:`properties.runner.run_property`).

A check is a function of one drawn example that returns ``(ratio, digits)``:
``ratio`` is the worst error / tolerance (a pass needs ``ratio <= 1``) and
``digits`` the correct significant digits where that is meaningful. The
runner :func:`run_property` drives it with Hypothesis (shrinking a failure to
a minimal example) and records the number of examples, the worst ratio and
the falsifying example.

Core checks (issue "the core"):

``routes_agree`` (vier9)
    the reference's closed formulas against inverting the ``2n x 2n`` matrix
    of omega_L, at 50 digits, tolerance ``1e-40 * max|P|``;
``fast_matches_reference`` (vier9)
    the fast implementation against the rigorous judge (Arb balls at 200 bits,
    :mod:`refimpl.rigorous`), tolerance the fast implementation's own per-point error
    bound, judged with the proven upper bound of the error (proven digits);
``reference_inside_balls`` (vier9)
    the mpmath reference (50 digits), the independent second route, within
    ``10^-45 max|P|`` of the balls;
``precision_ladder``
    the reference at dps 30 and 60 against dps 120, tolerance
    ``10^-(dps-3) * max|P|``;
``flow_reference_inside_balls`` (vier10, vier11)
    the flows' second route: the mpmath reference trajectory (30 digits) within its own promise
    ``10^-22 max(1, |state|)`` of the proven boxes of the whole state (refimpl.rigorous's
    ``judge_flow``, the judge of the certification's flow checks: float64 intervals where
    ``Upsilon = 0``, checked against the 64-bit Arb balls too; the Arb balls otherwise), ``pi`` and
    ``x``, both signs of ``t``, ``Upsilon`` of either kind; the digits are the reference's proven
    digits;
(``h2_published`` and ``h2_invariants``, judged by published tables, are oracles:
:mod:`oracles.h2_checks`.)
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
from hypothesis import strategies as st

from tstarg.refimpl import CATALOGUE_NAMES, catalogue
from tstarg.refimpl.accuracy import correct_digits as _digits
from tstarg.refimpl.accuracy import max_abs_diff as _mp_max_abs_diff
from tstarg.refimpl.fast import implementation as fast
from tstarg.refimpl.flows import reference_trajectory
from tstarg.refimpl.reference import DegeneratePointError, Reference
from tstarg.refimpl.rigorous import (
    INTERVAL_JUDGE,
    Rigorous,
    UndecidedError,
    error_bounds,
    judge_flow,
)

from .runner import CheckResult, run_property
from .strategies import REGIMES, cocycles, points, rationals, upsilons

__all__ = [
    "CORE_CHECKS",
    "core_checks",
    "routes_agree",
    "fast_matches_reference",
    "precision_ladder",
    "reference_inside_balls",
    "flow_reference_inside_balls",
]


# ------------------------------------------------------------------ strategies
@st.composite
def _model_and_point(draw, names=CATALOGUE_NAMES, exact=True, regime="generic"):
    name = draw(st.sampled_from(list(names)), label="algebra")
    alg = catalogue(name)
    n = alg.dim
    theta = draw(cocycles(alg, exact=exact), label="theta")
    ups = draw(
        upsilons(n, exact=exact, zero=False if regime == "near_degenerate" and n > 1 else None),
        label="upsilon",
    )
    if exact:
        vec = st.lists(rationals(denominator=10), min_size=n, max_size=n)
        return name, theta, ups, draw(vec, label="x"), draw(vec, label="pi")
    x, pi = draw(points(alg, theta, ups, regime=regime), label="point")
    return name, theta, ups, x, pi


# ---------------------------------------------------------------------- checks
def routes_agree(example) -> tuple[float, float] | None:
    name, theta, ups, x, pi = example
    alg = catalogue(name)
    ref = Reference(50)
    try:
        P1 = ref.poisson_tensor_mp(alg, theta, ups, x, pi, route="closed")
    except DegeneratePointError:
        return None
    P2 = ref.poisson_tensor_mp(alg, theta, ups, x, pi, route="first_principles")
    diff, scale = _mp_max_abs_diff(P1, P2)
    return float(diff / (mpmath.mpf(10) ** -40 * scale)), _digits(diff, scale)


_JUDGE = Rigorous(200)


def fast_matches_reference(example) -> tuple[float, float] | None:
    """The fast tensor against the rigorous judge (Arb balls at 200 bits, which provably contain the
    exact tensor of the float64 inputs): the ratio uses the proven upper bound of the error, so a
    pass is proven; the digits are proven digits."""
    name, theta, ups, x, pi = example
    alg = catalogue(name)
    res = fast.poisson_batch(alg.f, theta, ups, x, pi)
    if res.degenerate:
        return None
    try:
        balls = _JUDGE.poisson_tensor_balls(alg.f, theta, ups, x, pi)
    except (DegeneratePointError, UndecidedError):
        return None
    _, hi = error_bounds(res.P, balls)
    err = float(np.max(hi))
    scale = max(1.0, float(np.max(np.abs(balls.mid))))
    digits = float("inf") if err == 0 else -math.log10(err / scale)
    return err / float(res.error_bound), digits


def reference_inside_balls(example) -> tuple[float, float] | None:
    """The second route: the mpmath reference at 50 digits lies within its own promise
    (``10^-45 max|P|``) of the rigorous balls at 200 bits; the digits are the reference's proven
    digits."""
    name, theta, ups, x, pi = example
    alg = catalogue(name)
    try:
        Pm = Reference(50).poisson_tensor_mp(alg.f, theta, ups, x, pi)
        P = np.array([[Pm[i, j] for j in range(Pm.cols)] for i in range(Pm.rows)], dtype=object)
        balls = _JUDGE.poisson_tensor_balls(alg.f, theta, ups, x, pi)
    except (DegeneratePointError, UndecidedError):
        return None
    _, hi = error_bounds(P, balls)
    scale = max(1.0, float(np.max(np.abs(balls.mid))))
    err = float(np.max(hi))
    return err / (1e-45 * scale), (float("inf") if err == 0 else -math.log10(err / scale))


FLOW_REF_DPS = 30


@st.composite
def _flow_model(draw):
    name, theta, ups, x, pi = draw(
        _model_and_point([n for n in CATALOGUE_NAMES if catalogue(n).dim <= 4], exact=False)
    )
    t = draw(st.sampled_from([0.2, -0.2, 0.5]), label="t")
    return name, theta, ups, x, pi, t


def flow_reference_inside_balls(example) -> tuple[float, float] | None:
    """The second route of the flow judge: the mpmath reference trajectory (``FLOW_REF_DPS`` digits,
    Gragg-Bulirsch-Stoer with its own re-basing) against the proven boxes of ``judge_flow`` -- the
    route that judges (float64 intervals with Lohner's wrapping where ``Upsilon = 0``, Arb balls at 64
    bits otherwise) and, where that was the interval route, the Arb balls too (two proven enclosures
    of one state: the reference must lie in both): the proven lower bound of its distance to the
    exact state must be within the reference's promise ``10^-(dps - 8) max(1, |state|)`` (its
    per-step tolerance is ``10^-(dps + 5)``); the digits are the proven upper bound of its error by the
    judging route. A refusal by either route (the degenerate set, no exact representation, the
    logarithm not proven unique, a budget) is not judged."""

    name, theta, ups, x, pi, t = example
    alg = catalogue(name)
    n = alg.dim
    inertia = np.diag(np.linspace(1.0, 2.0, n))
    try:
        judged = judge_flow(alg, theta, ups, inertia, None, x, pi, t, max_seconds=4.0)
        encs = [judged["enclosure"]]
        if judged["judge"] == INTERVAL_JUDGE:
            a = judge_flow(alg, theta, ups, inertia, None, x, pi, t, max_seconds=4.0, route="arb")
            encs.append(a["enclosure"])
        tr = reference_trajectory(alg, theta, ups, inertia, None, x, pi, [0, t], dps=FLOW_REF_DPS)
    except ValueError:
        return None
    if any(e.x is None for e in encs):
        return None
    worst, digits = 0.0, math.inf
    for k, e in enumerate(encs):
        parts = [(e.pi, tr.pi[-1])]
        if np.max(np.abs(np.array(tr.x[-1], dtype=float) - e.x.mid)) < 1e-8:
            parts.append((e.x, tr.x[-1]))  # else the reference's x is another logarithm: pi judges
        for B, ref in parts:
            ref = np.asarray(ref, dtype=object)
            lo, hi = B.error_bounds(ref)
            scale = max(1.0, float(np.max(np.abs(B.mid))))
            worst = max(worst, float(np.max(lo)) / (10.0 ** -(FLOW_REF_DPS - 8) * scale))
            if k == 0:
                err = float(np.max(hi))
                digits = min(digits, math.inf if err == 0 else -math.log10(err / scale))
    return worst, digits


def precision_ladder(example) -> tuple[float, float] | None:
    name, theta, ups, x, pi = example
    alg = catalogue(name)
    try:
        Ps = {d: Reference(d).poisson_tensor_mp(alg, theta, ups, x, pi) for d in (30, 60, 120)}
    except DegeneratePointError:
        return None
    worst, digits = 0.0, float("inf")
    for d in (30, 60):
        diff, scale = _mp_max_abs_diff(Ps[d], Ps[120])
        worst = max(worst, float(diff / (mpmath.mpf(10) ** -(d - 3) * scale)))
        digits = min(digits, _digits(diff, scale))
    return worst, digits


def core_checks(max_examples: int, seed: int | None = 0) -> list[CheckResult]:
    """The checks of the core issue, at a Hypothesis budget of ``max_examples`` per check."""
    small = [n for n in CATALOGUE_NAMES if catalogue(n).dim <= 6]
    out = [
        run_property(
            "routes_agree",
            "vier3, vier9",
            routes_agree,
            _model_and_point(),
            max_examples=max_examples,
            seed=seed,
            extra={"tolerance": "1e-40 max|P| at dps 50"},
        ),
        run_property(
            "precision_ladder",
            "vier9",
            precision_ladder,
            _model_and_point(small),
            max_examples=max(3, max_examples // 4),
            seed=seed,
            extra={"tolerance": "10^-(dps-3) max|P|, dps 30/60 vs 120"},
        ),
    ]
    for regime in REGIMES:
        names = [n for n in CATALOGUE_NAMES if regime != "near_degenerate" or catalogue(n).f.any()]
        out.append(
            run_property(
                f"fast_matches_reference[{regime}]",
                "vier9",
                fast_matches_reference,
                _model_and_point(names, exact=False, regime=regime),
                max_examples=max_examples,
                seed=seed,
                extra={
                    "tolerance": "per-point error_bound of refimpl.fast",
                    "judge": f"{_JUDGE.name} (Arb balls, 200 bits): proven digits",
                },
            )
        )
    out.append(
        run_property(
            "reference_inside_balls",
            "vier9",
            reference_inside_balls,
            _model_and_point(names, exact=False),
            max_examples=max(3, max_examples // 4),
            seed=seed,
            extra={
                "tolerance": "10^-45 max|P| (reference at dps 50) from the 200-bit balls",
                "judge": "refimpl.rigorous; second route refimpl.reference",
            },
        )
    )
    out.append(
        run_property(
            "flow_reference_inside_balls",
            "vier10, vier11",
            flow_reference_inside_balls,
            _flow_model(),
            max_examples=max(3, max_examples // 4),
            seed=seed,
            extra={
                "tolerance": f"10^-{FLOW_REF_DPS - 8} max(1, |state|) (reference at dps "
                f"{FLOW_REF_DPS}) from the proven balls",
                "judge": f"refimpl.rigorous.judge_flow ({INTERVAL_JUDGE} where Upsilon = 0, "
                "checked against tstarg-rigorous (Arb balls, 64 bits) too; the Arb balls where "
                "Upsilon != 0); second route refimpl.flows.reference_trajectory",
            },
        )
    )
    return out


CORE_CHECKS = (
    "routes_agree",
    "precision_ladder",
    "fast_matches_reference",
    "reference_inside_balls",
    "flow_reference_inside_balls",
)
