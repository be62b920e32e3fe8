"""The proven flow judge of the certification (reports/certification/_common.py ``_proven_state``, used by
``flow.reference``): its answer against the mpmath reference flow (an independent route, 30 digits),
its refusal by name, and the certificate that names it."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from tstarg.refimpl import su2
from tstarg.refimpl.flows import reference_trajectory
from tstarg.refimpl.rigorous import INTERVAL_JUDGE
from tstarg.reports.certification import _common
from tstarg.reports.certification._common import PROVEN_JUDGE, _proven_state

Z3 = np.zeros((3, 3))
GRAV = {"kind": "gravity", "L": np.array([0.0, 0.0, 1.0]), "gamma": np.array([0.0, 0.0, -1.0])}
INERTIA = np.diag([1.0, 2.0, 3.0])
X0, PI0 = np.array([0.1, 0.2, -0.3]), np.array([0.3, 0.2, 0.5])
# Upsilon = tau.f with tau = (0, 0, 1/2): the plane pi_3 = 2 is the degenerate set (exact in binary)
U_DEG = np.einsum("l,lmn->mn", np.array([0.0, 0.0, 0.5]), su2().f)


def test_proven_state_holds_the_reference_with_upsilon_and_both_signs():
    """``|value - exact| <= err`` is the judge's promise: the 30-digit reference (its own error ~1e-25,
    far below the 64-bit balls' ~1e-17) must lie within it, for ``t`` of either sign; the judge is
    also not vacuous (its error is below 1e-12 while the state moves by > 1e-2)."""
    f = su2().f
    for t in (0.5, -0.5):
        out = _proven_state(f, Z3, U_DEG * 0.6, INERTIA, GRAV, X0, PI0, t)
        assert isinstance(out, tuple), out
        xm, pm, ex, ep, judge = out
        assert judge.startswith("tstarg-rigorous (Arb balls")  # Upsilon != 0: the Arb route
        assert ex < 1e-12 and ep < 1e-12
        tr = reference_trajectory(f, Z3, U_DEG * 0.6, INERTIA, GRAV, X0, PI0, [0, t], dps=30)
        xr, pr = tr.x[-1], tr.pi[-1]  # mpf: not rounded to float64
        with mpmath.workdps(40):
            for got, ref, err in ((xm, xr, ex), (pm, pr, ep)):
                for a, b in zip(got, ref):
                    assert abs(mpmath.mpf(float(a)) - mpmath.mpf(b)) <= err * (1 + 1e-12) + 1e-25
        assert np.max(np.abs(pm - PI0)) > 1e-2


def test_proven_state_refuses_by_name_on_the_degenerate_set():
    out = _proven_state(su2().f, Z3, U_DEG, INERTIA, None, X0, np.array([0.1, 0.2, 2.0]), 0.5)
    assert isinstance(out, str) and "DegeneratePointError" in out and "Delta" in out


def test_certificate_names_the_proven_judge_and_its_error():
    """flow.reference on refimpl.fast (3 examples): the certificate's judge line and the check's
    counts name the balls, and the judge's error is stated and far below the tolerance."""
    from tstarg.refimpl.fast import implementation as fast
    from tstarg.reports.certification import certify

    assert PROVEN_JUDGE in _common.JUDGE
    cert = certify(fast, max_examples=3, seed=0, checks=["flow.reference"], shrink=False)
    (res,) = cert.checks
    assert res.passed, cert.summary()
    judged = res.extra.get(f"forward legs judged by {INTERVAL_JUDGE}", 0)
    assert judged >= 1, res.extra
    assert 0 < res.extra["judge_error"] < 1e-9
    assert PROVEN_JUDGE in res.extra["judge"]


def _move_reference(monkeypatch, rel: str) -> None:
    """Verify's second route from here on sees the reference's final pi moved by ``rel`` (relative)."""
    import tstarg.refimpl.flows as flows
    from tstarg.properties import core_checks

    real = flows.reference_trajectory

    def moved(*a, **k):
        tr = real(*a, **k)
        tr.pi[-1] = tr.pi[-1] * (1 + mpmath.mpf(rel))
        return tr

    monkeypatch.setattr(core_checks, "reference_trajectory", moved)


def test_verify_flow_second_route_passes_and_bites(monkeypatch):
    """verify's ``flow_reference_inside_balls`` on one su(2) example with Upsilon: the true reference
    passes (ratio <= 1, > 14 proven digits); a reference whose pi is moved by 1e-15 relative (far
    above its 1e-22 promise, far below any float64 tolerance) fails it."""
    from tstarg.properties.core_checks import flow_reference_inside_balls

    ex = ("su(2)", Z3, U_DEG * 0.6, X0, PI0, 0.2)
    ratio, digits = flow_reference_inside_balls(ex)
    assert ratio <= 1 and digits > 14
    _move_reference(monkeypatch, "1e-15")
    bad, _ = flow_reference_inside_balls(ex)
    assert bad > 1e3


def test_verify_flow_second_route_holds_both_boxes(monkeypatch):
    """With Upsilon = 0 the verify check judges the reference against the interval boxes and the Arb
    balls: the true reference passes with >= 13 proven digits (the boxes' radius ~1e-16 at t = 0.2);
    a reference whose pi is moved by 1e-12 relative (outside the interval box, whose radius is
    below 1e-14 here, and far outside the Arb balls) fails."""
    from tstarg.properties.core_checks import flow_reference_inside_balls

    ex = ("su(2)", Z3, Z3, X0, PI0, -0.2)
    from tstarg.refimpl.rigorous import judge_flow

    assert judge_flow(su2(), Z3, Z3, np.diag([1.0, 1.5, 2.0]), None, X0, PI0, -0.2)["judge"] == (
        INTERVAL_JUDGE
    )
    ratio, digits = flow_reference_inside_balls(ex)
    assert ratio <= 1 and digits > 13
    _move_reference(monkeypatch, "1e-12")
    ratio, _ = flow_reference_inside_balls(ex)
    assert ratio > 1


def test_flow_long_judges_by_the_boxes_and_accepts_a_flow_that_does_not_rebase():
    """flow.long on the closed form of the free top with I = 1, x0 = 0 (Omega = pi constant, so
    x(t) = t pi0 exactly, carried on without re-basing): at pi0 = (0, 0, 1.5) it reaches |x| = 15 at
    t = 10, a rotation whose principal SU(2) logarithm is (0, 0, 15 - 4 pi); the boxes judge it (their
    x is principal, the flow's is not: rho(g) and Ad(g) decide, chart-free) and it passes; the same
    flow off by 1e-6 in pi past |t| = 5 fails against the boxes."""
    from tstarg.reports.certification import REGISTRY
    from tstarg.reports.certification.checks.flow_long import FlowLongExample
    from tstarg.reports.certification.domain import Domain
    from tstarg.reports.certification.models import Hamiltonian

    class Closed:
        name, version, flow_tolerance = "closed form", "test", 1e-12
        off = 0.0

        def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):
            p = np.array(pi0, dtype=float)
            return np.asarray(x0, dtype=float) + t * p, p * (1 + (self.off if abs(t) > 5 else 0))

    f = su2().f
    model = ("su(2)", f, Z3, Z3, np.zeros(3), np.array([0.0, 0.0, 1.5]))
    ex = FlowLongExample(Hamiltonian(model, np.eye(3), None), 0.5, 1.0)
    stats: dict = {}
    body, _ = REGISTRY["flow.long"].build(Closed(), Domain(), stats)
    ratio, _ = body(ex)
    assert ratio <= 1 and stats.get(f"examples judged by {INTERVAL_JUDGE}") == 1, stats
    assert stats["judge error (proven, worst) / tolerance"] < 0.01
    assert stats["largest |t| judged"] == 10.0
    bad = Closed()
    bad.off = 1e-6
    body, _ = REGISTRY["flow.long"].build(bad, Domain(), {})
    with pytest.raises(AssertionError, match="ratio"):
        body(ex)
