"""The whole state in float64 intervals (refimpl/_interval_state.py) and the flow judge's routes
(refimpl/_flow_judge.py) against independent routes.

* containment: the mpmath reference trajectory (refimpl.flows, Gragg-Bulirsch-Stoer at 30 digits in
  the default run, 60 in the slow one, re-based in its representation; its error ``<= 10^-(dps-8)``) lies inside every box of ``pi``, ``Gamma``,
  ``rho(g)`` (real and imaginary parts) and ``x``, and a value moved by twice the box's radius lies
  outside (the box is not vacuous); every box overlaps the Arb route's 64-bit balls of the same state
  (two enclosures of one exact value must meet). se(3), so(4) (backwards), sl(2,R), Bianchi VI_h with
  Theta, su(2) with gravity (a heavy top); su(3) with Theta in the slow run (its reference costs
  ~10-40 s).
* the judge: its route and name per case, its refusals and fall-back by name.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
from flint import arb

from tstarg.oracles.float_judge import expm
from tstarg.refimpl import _flow_judge as fj
from tstarg.refimpl import catalogue, su2
from tstarg.refimpl.flows import reference_trajectory
from tstarg.refimpl.rigorous import (
    INTERVAL_JUDGE,
    arb_judge_name,
    full_state_enclosure,
    interval_state_enclosure,
    interval_state_enclosures,
    judge_flow,
)

GRAV = {"kind": "gravity", "L": np.array([0.0, 0.0, 1.0]), "gamma": np.array([0.0, 0.0, -1.0])}


def _ref_err(dps: int) -> float:
    """The reference's promise at ``dps`` digits (its step tolerance is ``10^-(dps + 5)``): at 30 digits
    1e-22, six orders below the boxes' radii (>= 1e-16), so containment is still a sharp test."""
    return 10.0 ** -(dps - 8)


def _case(name, theta_xi, grav, t, seed):
    alg = su2() if name == "su(2)" else catalogue(name)
    n = alg.f.shape[0]
    rng = np.random.default_rng(seed)
    theta = (
        -np.einsum("k,kab->ab", 0.3 * rng.normal(size=n), alg.f) if theta_xi else np.zeros((n, n))
    )
    inertia = np.diag(rng.uniform(0.5, 2.0, size=n))
    return (
        alg,
        theta,
        np.zeros((n, n)),
        inertia,
        grav,
        0.4 * rng.normal(size=n),
        rng.normal(size=n),
        t,
    )


def _split(gs):
    g = np.asarray(gs, dtype=object)
    re = np.vectorize(lambda v: mpmath.re(v), otypes=[object])(g)
    im = np.vectorize(lambda v: mpmath.im(v), otypes=[object])(g)
    return re, im


def _contained(B, ref, what, dps):
    err = _ref_err(dps)
    ref = np.asarray(ref, dtype=object)
    dist = B.error_bounds(ref)[0]
    assert dist.max() <= err, f"{what}: the reference is {dist.max():.3g} outside the box"
    k = int(np.argmax(B.rad))
    moved = ref.copy()
    with mpmath.workdps(dps + 10):
        moved.flat[k] = moved.flat[k] + mpmath.mpf(2 * B.rad.flat[k] + 2 * err)
    assert B.error_bounds(moved)[0].flat[k] > 0, f"{what}: a value moved by 2 rad is still inside"


def _overlap(a, b, what):
    for u, ru, v, rv in zip(a.mid.flat, a.rad.flat, b.mid.flat, b.rad.flat):
        assert arb(float(u), float(ru)).overlaps(arb(float(v), float(rv))), what


# (name, Theta, gravity, t, seed): the default run at t ~ 0.2 and 30 digits (~1-3 s of reference
# each); the slow run at the 60 digits and longer times, su(3) included
CASES = [
    ("se(3)", False, None, 0.2, 1),
    ("so(4)", False, None, -0.2, 2),
    ("sl(2,R)", False, None, 0.2, 3),
    ("Bianchi VI_h(h=-1/4)", True, None, 0.2, 4),
    ("su(2)", False, GRAV, 0.3, 5),
]
SLOW_CASES = [
    ("se(3)", False, None, 0.5, 1),
    ("so(4)", False, None, -0.4, 2),
    ("sl(2,R)", False, None, 0.5, 3),
    ("Bianchi VI_h(h=-1/4)", True, None, 0.3, 4),
    ("su(2)", False, GRAV, 1.0, 5),
    ("su(3)", True, None, 0.2, 6),
]


def _check(name, theta_xi, grav, t, seed, dps):
    args = _case(name, theta_xi, grav, t, seed)
    e = interval_state_enclosure(*args)
    assert e.method == "float64 intervals, Lohner" and e.t == t
    assert e.max_rad() < 1e-10  # not vacuous: far below every float64 flow tolerance
    tr = reference_trajectory(*args[:-1], [0, t], dps=dps)
    what = f"{name}, t = {t}"
    _contained(e.pi, tr.pi[-1], f"{what}: pi", dps)
    if grav is not None:
        _contained(e.Gamma, tr.Gamma[-1], f"{what}: Gamma", dps)
    re, im = _split(tr.g[-1])
    _contained(e.rho_g, re, f"{what}: Re rho(g)", dps)
    if e.rho_g_imag is not None:
        _contained(e.rho_g_imag, im, f"{what}: Im rho(g)", dps)
    assert e.x is not None, e.x_note
    if np.max(np.abs(np.array(tr.x[-1], dtype=float) - e.x.mid)) < 1e-8:
        _contained(e.x, tr.x[-1], f"{what}: x", dps)
    else:  # the reference re-based onto another logarithm: rho(g) above decided
        assert np.linalg.norm(e.x.mid) > 1.0
    a = full_state_enclosure(*args, prec_bits=64)
    for part in ("pi", "Gamma", "rho_g", "rho_g_imag", "x"):
        if getattr(e, part) is not None:
            _overlap(getattr(e, part), getattr(a, part), f"{what}: {part} vs the Arb balls")


@pytest.mark.parametrize(("name", "theta_xi", "grav", "t", "seed"), CASES)
def test_interval_state_contains_the_reference_and_meets_the_balls(name, theta_xi, grav, t, seed):
    _check(name, theta_xi, grav, t, seed, 30)


@pytest.mark.slow
@pytest.mark.parametrize(("name", "theta_xi", "grav", "t", "seed"), SLOW_CASES)
def test_interval_state_contains_the_60_digit_reference(name, theta_xi, grav, t, seed):
    _check(name, theta_xi, grav, t, seed, 60)


def test_several_times_continue_from_box_to_box():
    """Times reached in one run (continued from the box at the earlier time) against separate runs:
    two enclosures of one exact state overlap; times come back in the caller's order."""
    args = _case("su(2)", False, GRAV, None, 5)[:-1]
    es = interval_state_enclosures(*args, [-2.0, -0.5], want_ad=True)
    assert [e.t for e in es] == [-2.0, -0.5]
    for e in es:
        one = interval_state_enclosure(*args, e.t, want_ad=True)
        for part in ("pi", "Gamma", "rho_g", "rho_g_imag", "Ad_g", "x"):
            _overlap(getattr(e, part), getattr(one, part), f"t = {e.t}: {part}")
    # Ad(g) carried by its own rows is Ad of the x proven from rho(g) (first principles: exp(ad_x))
    e = es[0]
    f = su2().f
    A = np.einsum("a,mab->mb", e.x.mid, f)
    Ad = expm(A)
    # the judge side's scaled expm (float_judge.expm: within 16 ulp to 1-norm 16) of a 3x3 skew
    # matrix of norm < 7: error < 1e-13; the boxes' radii are below 1e-12
    assert np.max(np.abs(Ad - e.Ad_g.mid)) < 1e-11


def test_judge_routes_and_names():
    """Upsilon = 0: the interval route answers, named; Upsilon != 0: the Arb route, named with its
    precision; both enclose the same state where both answer (their balls overlap)."""
    args = _case("su(2)", False, GRAV, 0.5, 5)
    out = judge_flow(*args)
    assert out["judge"] == INTERVAL_JUDGE and out["refused"] == ""
    arb_out = judge_flow(*args, route="arb")
    assert arb_out["judge"] == arb_judge_name(64)
    _overlap(out["enclosure"].pi, arb_out["enclosure"].pi, "pi: interval vs Arb")
    U = np.einsum("l,lmn->mn", np.array([0.0, 0.0, 0.3]), su2().f)
    a = list(args)
    a[2] = U
    up = judge_flow(*a)
    assert up["judge"] == arb_judge_name(64)
    assert "Upsilon" in up["refused"]
    with pytest.raises(ValueError, match="Upsilon"):
        judge_flow(*a, route="interval")
    with pytest.raises(ValueError, match="route must be one of"):
        judge_flow(*args, route="mpmath")


def test_judge_falls_back_to_the_balls_when_the_intervals_refuse(monkeypatch):
    def refuse(*a, **k):
        raise ValueError("interval flow: step size underflow after 3 steps")

    monkeypatch.setattr(fj, "interval_state_enclosures", refuse)
    args = _case("se(3)", False, None, 0.3, 1)
    out = judge_flow(*args)
    assert out["judge"] == arb_judge_name(64) and "underflow" in out["refused"]
    assert np.max(out["pi"][1]) < 1e-15


def test_interval_state_refuses_bad_input_by_name():
    args = list(_case("se(3)", False, None, 0.3, 1))
    with pytest.raises(ValueError, match="one sign"):
        interval_state_enclosures(*args[:-1], [0.5, -0.5])
    with pytest.raises(ValueError, match="tol must be"):
        interval_state_enclosure(*args, tol=0.0)
    with pytest.raises(ValueError, match="t must be"):
        interval_state_enclosure(*args[:-1], 1e9)
    x0 = args[5].copy()
    interval_state_enclosure(*args)
    assert np.array_equal(args[5], x0)  # the caller's arrays are not touched
