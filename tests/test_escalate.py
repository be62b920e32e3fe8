"""tstarg.refimpl.escalate: every point is within the requested tolerance, or flagged; none is dropped.

Expected values come from the mpmath reference at 80 digits (the escalation itself runs a
ladder of at most ~75 digits and stops at the first agreement), from the su(2) closed form
Delta = C1^2 (section cinq) in exact rational arithmetic, and from the fast implementation's
own batch where nothing may change.
"""

from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest

from tstarg.refimpl import catalogue, su2
from tstarg.refimpl.escalate import delta_exact, poisson_within, vector_field_within
from tstarg.refimpl.fast import implementation as fast
from tstarg.refimpl.reference import Reference

JUDGE = Reference(80)
TAU = np.array([0.25, -0.5, 0.5])  # dyadic: C1 = 1 - pi'.tau = 0 is reachable exactly
XI = np.array([0.125, 0.25, -0.125])
X = np.array([0.3, -0.2, 0.5])


def _tau_matrix(t):
    return np.array([[0.0, t[2], -t[1]], [-t[2], 0.0, t[0]], [t[1], -t[0], 0.0]])


def _theta(xi):
    return -_tau_matrix(
        xi
    )  # Theta_ab = -xi_k eps_kab has the same layout as Upsilon^mn = tau_l eps_lmn


def _su2_near_degenerate(ks):
    """pi with C1 = 1 - (pi + xi).tau = 10^-k (plus a component orthogonal to tau)."""
    d = TAU / (TAU @ TAU)
    w = np.array([0.2, 0.3, 0.0])
    w = w - (w @ TAU) * d
    return np.array([(1 - 10.0**-k) * d - XI + w for k in ks])


def _max_err(values, ref_mp):
    """``(max |values - ref|, max(1, max|ref|))`` evaluated at 100 digits."""
    with mpmath.workdps(100):
        ref = [mpmath.mpf(v) for v in ref_mp]
        err = max(abs(mpmath.mpf(float(a)) - b) for a, b in zip(np.ravel(values), ref))
        return float(err), float(max([mpmath.mpf(1)] + [abs(v) for v in ref]))


def test_within_tolerance_or_flagged_near_degenerate_su2():
    """su(2) toward C1 = 0: every unflagged point is within tol * max(1, max|P|) of the 80-digit reference."""
    alg = su2()
    ks = [1, 4, 7, 10, 13, 14, 15]
    pi = _su2_near_degenerate(ks)
    x = np.tile(X, (len(ks), 1))
    tol = 1e-12
    res = poisson_within(alg.f, _theta(XI), _tau_matrix(TAU), x, pi, tol)
    assert res.P.shape == (len(ks), 6, 6) and res.flagged.shape == (len(ks),)
    assert res.escalated.sum() >= 4, "points with cond ~ 1e7 .. 1e15 need escalation at tol 1e-12"
    for k in range(len(ks)):
        assert not res.flagged[k], (
            f"C1 = 1e-{ks[k]} is not on Pi_1 and must be resolved, got {res.reason[k]}"
        )
        M = JUDGE.poisson_tensor_mp(alg.f, _theta(XI), _tau_matrix(TAU), x[k], pi[k])
        err, scale = _max_err(res.P[k], M)
        # contract: err <= error_bound <= allowed = tol * max(1, max|P|) (relative tolerance)
        assert err <= res.error_bound[k] <= res.allowed[k] * (1 + 1e-12), (
            f"C1 = 1e-{ks[k]}: err {err:.3g}, bound {res.error_bound[k]:.3g}, allowed {res.allowed[k]:.3g}"
        )
        assert err <= tol * scale * (1 + 1e-12)


def test_ok_points_are_untouched_fast_values():
    """Points whose bound meets the tolerance keep the fast implementation's value bit for bit."""
    alg = su2()
    pi = _su2_near_degenerate([1, 2, 9])
    x = np.tile(X, (3, 1))
    res = poisson_within(alg.f, _theta(XI), _tau_matrix(TAU), x, pi, 1e-8)
    ref = fast.poisson_batch(alg.f, _theta(XI), _tau_matrix(TAU), x, pi)
    ok = ~res.escalated & ~res.flagged
    assert ok[:2].all() and res.escalated[2], (
        "C1 = 1e-9 has bound ~1e-7 relative: escalated at tol 1e-8"
    )
    np.testing.assert_array_equal(res.P[ok], ref.P[ok])
    np.testing.assert_array_equal(res.error_bound[ok], ref.error_bound[ok])


def test_escalate_false_flags_exactly_the_points_over_tolerance():
    """escalate=False: flagged == (error_bound > tol * max(1, max|P|)) and the values are the fast ones."""
    alg = su2()
    pi = _su2_near_degenerate([1, 3, 6, 9, 12, 15])
    x = np.tile(X, (6, 1))
    tol = 1e-10
    res = poisson_within(alg.f, _theta(XI), _tau_matrix(TAU), x, pi, tol, escalate=False)
    ref = fast.poisson_batch(alg.f, _theta(XI), _tau_matrix(TAU), x, pi)
    with np.errstate(invalid="ignore"):
        scale = np.maximum(1.0, np.max(np.abs(ref.P), axis=(1, 2)))
        expected = ~(ref.error_bound <= tol * scale) | ref.degenerate
    np.testing.assert_array_equal(res.flagged, expected)
    assert not res.escalated.any() and expected.any() and not expected.all()
    np.testing.assert_array_equal(res.P, ref.P)  # NaN where degenerate, in place: nothing dropped


def test_exactly_degenerate_point_flagged_never_escalated_nor_dropped():
    """A point with C1 = 0 exactly (Delta = 0, vier12) in the middle of a batch: NaN, flagged, in place."""
    alg = su2()
    pi = _su2_near_degenerate([2, 2, 3])
    pi[1] = np.array([0.0, 0.0, 2.0]) - XI  # pi' = (0, 0, 2): pi'.tau = 1 exactly
    assert (
        Fraction(1) - sum(Fraction(float(a)) * Fraction(float(b)) for a, b in zip(pi[1] + XI, TAU))
        == 0
    )
    x = np.tile(X, (3, 1))
    res = poisson_within(alg.f, _theta(XI), _tau_matrix(TAU), x, pi, 1e-10)
    assert res.P.shape == (3, 6, 6)
    assert res.flagged.tolist() == [False, True, False] and not res.escalated[1]
    assert np.all(np.isnan(res.P[1])) and np.isinf(res.error_bound[1])
    assert "Delta = 0" in res.reason[1]
    assert np.all(np.isfinite(res.P[[0, 2]]))


def test_delta_exact_is_c1_squared_for_su2():
    """delta_exact equals the closed form Delta = C1^2, C1 = 1 - (pi + xi).tau (section cinq), in rationals."""
    alg = su2()
    rng = np.random.default_rng(3)
    for _ in range(4):
        pi = (
            np.round(rng.standard_normal(3) * 64) / 64
        )  # dyadic, so the closed form is exact in Fractions
        c1 = 1 - sum(
            (Fraction(float(p)) + Fraction(float(q))) * Fraction(float(t))
            for p, q, t in zip(pi, XI, TAU)
        )
        d = delta_exact(alg.f, _theta(XI), _tau_matrix(TAU), pi)
        assert Fraction(int(d.p), int(d.q)) == c1**2


def test_generic_algebras_near_degenerate():
    """Bianchi VI_h and so(4) (generic path) toward Delta = 0: within the tolerance of the reference."""
    for name in ("Bianchi VI_h(h=-1/4)", "so(4)"):
        alg = catalogue(name)
        n = alg.dim
        rng = np.random.default_rng(5)
        A = rng.standard_normal((n, n)) / 2
        U = A - A.T
        v = rng.standard_normal(n)
        with mpmath.workdps(50):
            M = mpmath.matrix(np.einsum("m,mab->ab", v, alg.f).tolist()) * mpmath.matrix(U.tolist())
            ev = [
                mpmath.re(e)
                for e in mpmath.eig(M, left=False, right=False)
                if abs(mpmath.im(e)) < 1e-20 and abs(e) > 1e-3
            ]
            assert ev, f"{name}: the fixture needs a real eigenvalue of S(v) U"
            s = -1 / max(ev, key=abs)
            pis = np.array([float(s * (1 - mpmath.mpf(10) ** -k)) * v for k in (3, 9, 13)])
        x = np.tile(0.2 * rng.standard_normal(n), (3, 1))
        tol = 1e-11
        res = poisson_within(alg.f, np.zeros((n, n)), U, x, pis, tol)
        assert res.escalated.any()
        for k in range(3):
            assert not res.flagged[k]
            ref = Reference(60).poisson_tensor_mp(alg.f, np.zeros((n, n)), U, x[k], pis[k])
            err, scale = _max_err(res.P[k], ref)
            assert err <= res.error_bound[k] and err <= tol * scale * (1 + 1e-12), (
                name,
                k,
                err,
                res.error_bound[k],
            )


def test_vector_field_within_heavy_top():
    """Heavy top near C1 = 0: (xdot, pidot) within tol of the 80-digit reference (vier10, vier11), or flagged at C1 = 0."""
    alg = su2()
    pi = _su2_near_degenerate([2, 8, 14, 0])
    pi[3] = np.array([0.0, 0.0, 2.0]) - XI
    x = np.tile(X, (4, 1))
    inertia = np.diag([1.0, 2.0, 3.0])
    pot = {"kind": "gravity", "L": [0.0, 0.0, 1.0], "gamma": [0.1, 0.2, 0.97]}
    tol = 1e-11
    res = vector_field_within(alg.f, _theta(XI), _tau_matrix(TAU), inertia, pot, x, pi, tol)
    assert res.xdot.shape == (4, 3) and res.flagged.tolist() == [False, False, False, True]
    assert res.escalated[1] and res.escalated[2]
    for k in range(3):
        xd, pd = JUDGE.hamiltonian_vector_field_mp(
            alg.f, _theta(XI), _tau_matrix(TAU), inertia, pot, x[k], pi[k]
        )
        err, scale = _max_err(np.concatenate([res.xdot[k], res.pidot[k]]), list(xd) + list(pd))
        assert err <= res.error_bound[k] and err <= tol * scale * (1 + 1e-12), (
            k,
            err,
            res.error_bound[k],
        )


def test_absolute_tolerance():
    """relative=False: allowed is tol itself, and the escalated values meet it against the reference."""
    alg = su2()
    pi = _su2_near_degenerate([5])
    res = poisson_within(alg.f, _theta(XI), _tau_matrix(TAU), X[None], pi, 1e-9, relative=False)
    assert (
        res.allowed[0] == 1e-9 and res.escalated[0]
    )  # |P| ~ 1e5: the fast bound (~1e-6) misses 1e-9
    err, _ = _max_err(
        res.P[0], JUDGE.poisson_tensor_mp(alg.f, _theta(XI), _tau_matrix(TAU), X, pi[0])
    )
    assert err <= res.error_bound[0] <= 1e-9


class _LooseBound:
    """The fast implementation with a bound inflated 1e8 times: escalation must follow the bound it is given."""

    def poisson_batch(self, *a, **k):
        import dataclasses

        r = fast.poisson_batch(*a, **k)
        return dataclasses.replace(r, error_bound=r.error_bound * 1e8)


def test_replaced_implementation_is_honoured(monkeypatch):
    """fast=None looks refimpl.fast.implementation up at call time; a looser bound escalates more points."""
    from tstarg import refimpl

    alg = su2()
    pi = _su2_near_degenerate([1])
    before = poisson_within(alg.f, _theta(XI), _tau_matrix(TAU), X[None], pi, 1e-10)
    monkeypatch.setattr(refimpl.fast, "implementation", _LooseBound())
    after = poisson_within(alg.f, _theta(XI), _tau_matrix(TAU), X[None], pi, 1e-10)
    assert not before.escalated[0] and after.escalated[0]


@pytest.mark.parametrize("tol", [0.0, -1e-3, float("nan"), float("inf"), "abc"])
def test_bad_tolerance_is_a_clear_value_error(tol):
    """tol must be a finite number > 0; the error names it."""
    with pytest.raises(ValueError, match="tol"):
        poisson_within(su2().f, np.zeros((3, 3)), np.zeros((3, 3)), X[None], X[None], tol)


def test_bad_dps_and_points_are_value_errors():
    """dps < 15 and mismatched x/pi shapes are refused with messages naming them."""
    with pytest.raises(ValueError, match="dps"):
        poisson_within(su2().f, np.zeros((3, 3)), np.zeros((3, 3)), X[None], X[None], 1e-10, dps=5)
    with pytest.raises(ValueError, match="same shape|last axis"):
        poisson_within(
            su2().f, np.zeros((3, 3)), np.zeros((3, 3)), X[None], np.zeros((2, 3)), 1e-10
        )
