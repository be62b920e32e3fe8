"""The bench's protocol-flow problems and their heyoka contenders (reports/_bench_protocol.py).

The heyoka system generated from a model is checked against routes that share none of its code:

* its field at points ``(pi, Ad(exp x))`` against the mpmath reference's protocol vector field
  (``Reference.hamiltonian_vector_field``, the Poisson tensor of vier9 contracted with dH, no solve of
  vier10/vier11 and no generated expression): ``pidot`` at any ``x``, and ``Rdot = ad(xdot)`` at
  ``x = 0`` (where ``L(g, e) = 1``, so ``xdot = Omega``);
* its trajectory against scipy's DOP853 on the protocol's ``(x, pi)`` system (the float vector field of
  ``refimpl.fast``, chart coordinates, ``R = expm(ad_x)`` at the end): two formulations of one flow;

for the Upsilon != 0 problem, the Bianchi cocycle and se(3) (Upsilon = 0), and the heavy top (gravity).
The physical inputs are checked against facts stated apart from their code (Lamb's sum rule, the
sphere's added mass, a cocycle not a coboundary).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from tstarg.refimpl import bianchi, check_cocycle, solve_coboundary
from tstarg.refimpl.fast import Fast
from tstarg.refimpl.reference import Reference
from tstarg.reports import _bench_protocol as bp

EPS = np.finfo(float).eps
FIELD_CASES = ("modified_su3", "bianchi_cocycle", "kirchhoff_se3", "heavy_top_full")


def test_lamb_coefficients_sum_rule_and_sphere():
    """alpha0 + beta0 + gamma0 = 2 for any ellipsoid (Lamb section 114: the three integrals sum to
    2 / (abc) times abc); a sphere has alpha0 = 2/3, added mass m_f / 2 and no added moment.
    Error model: quad at epsrel 1e-13 on each integral, summed: 1e-12 is slack."""
    for axes in [(1.0, 0.5, 0.25), (2.0, 1.1, 0.3), (1.0, 1.0, 1.0)]:
        assert abs(sum(bp.lamb_coefficients(*axes)) - 2.0) <= 1e-12
    a0 = bp.lamb_coefficients(1.0, 1.0, 1.0)
    assert np.allclose(a0, 2.0 / 3.0, rtol=0, atol=1e-12)
    M = bp.ellipsoid_inertia((1.0, 1.0, 1.0), 1.0, 1.0, (0.0, 0.0, 0.0))
    m = 4.0 / 3.0 * np.pi
    expected = np.diag([2 * m / 5] * 3 + [1.5 * m] * 3)  # rigid 2 m r^2 / 5; m + m_f / 2
    assert np.max(np.abs(M - expected)) <= 1e-12 * m


def test_kirchhoff_inertia_is_spd_and_couples_through_the_offset():
    """The offset body frame gives M_O = A^T M_C A: SPD, with angular-linear blocks
    m_total [offset]_x-shaped (nonzero), and the kinetic energy of a pure translation unchanged."""
    p = bp.protocol_problem("kirchhoff_se3")
    M = p.inertia
    assert np.all(np.linalg.eigvalsh(M) > 0)
    assert np.max(np.abs(M[:3, 3:])) > 0.01
    Mc = bp.ellipsoid_inertia((1.0, 0.5, 0.25), 1.0, 1.0, (0.0, 0.0, 0.0))
    v = np.array([0, 0, 0, 0.3, -0.2, 0.5])  # translation: every point moves with v
    assert abs(v @ M @ v - v @ Mc @ v) <= 1e-13 * (v @ Mc @ v)


def test_bianchi_theta_is_a_cocycle_but_not_a_coboundary():
    p = bp.protocol_problem("bianchi_cocycle")
    alg = bianchi("VI0")
    check_cocycle(alg, p.theta)
    with pytest.raises(ValueError, match="not a coboundary"):
        solve_coboundary(alg, p.theta)


hy = pytest.importorskip("heyoka")


def _field(p):
    sys_ = bp.heyoka_system(p.f, p.theta, p.upsilon, p.inertia, p.potential, p.pi0)
    return hy.cfunc([e for _, e in sys_], [v for v, _ in sys_])


@pytest.mark.parametrize("name", FIELD_CASES)
def test_heyoka_field_matches_the_reference_vector_field(name):
    """pidot of the generated system at (pi, Ad(exp x)) equals the mpmath reference's protocol vector
    field at (x, pi) (30 digits); at x = 0, Rdot = ad(xdot). Points: the problem's own start and two
    random ones near it. Error model: the generated field evaluates each entry as a rational function
    with at most n^2 products per sum and one LU solve by Psi: rounding <= 64 n^2 eps s cond(Psi),
    s = the largest term, bounded by (1 + max|pi|)^2 ||I^-1|| (1 + max|f|) (1 + max|Ad|)."""
    p = bp.protocol_problem(name)
    n = p.n
    cf = _field(p)
    ref = Reference(30)
    rng = np.random.default_rng(11)
    for k in range(3):
        x = p.x0 if k == 0 else p.x0 + 0.1 * rng.standard_normal(n)
        pi = p.pi0 if k == 0 else p.pi0 + 0.1 * rng.standard_normal(n)
        Ad = expm(bp.ad_matrix(p.f, x))
        rhs = cf(np.concatenate([pi, Ad.ravel()]))
        xd_ref, pd_ref = (
            np.array([float(v) for v in np.ravel(a)])
            for a in ref.hamiltonian_vector_field(
                p.f, p.theta, p.upsilon, p.inertia, p.potential, x, pi
            )
        )
        Psi = np.eye(n) + p.upsilon @ (np.einsum("m,mab->ab", pi, p.f) - p.theta)
        s = (
            (1 + np.max(np.abs(pi))) ** 2
            * np.linalg.norm(np.linalg.inv(p.inertia), 2)
            * (1 + np.max(np.abs(p.f)))
            * (1 + np.max(np.abs(Ad)))
        )
        tol = 64 * n * n * EPS * s * np.linalg.cond(Psi)
        assert np.all(np.isfinite(rhs))
        assert np.max(np.abs(rhs[:n] - pd_ref)) <= tol, (name, k)
        if k == 0:  # the R part at x = 0: R = 1, Rdot = ad(Omega), Omega = xdot there
            rhs0 = cf(np.concatenate([pi, np.eye(n).ravel()]))
            xd0, _ = (
                np.array([float(v) for v in np.ravel(a)])
                for a in ref.hamiltonian_vector_field(
                    p.f, p.theta, p.upsilon, p.inertia, p.potential, np.zeros(n), pi
                )
            )
            Rd = rhs0[n:].reshape(n, n)
            assert np.max(np.abs(Rd - bp.ad_matrix(p.f, xd0))) <= tol, name
    assert np.max(np.abs(xd_ref)) > 0  # the reference field is not trivially zero


@pytest.mark.parametrize("name", ["modified_su3", "kirchhoff_se3"])
def test_heyoka_trajectory_matches_the_chart_flow(name):
    """heyoka's (pi, R) flow to t = 0.5 against scipy DOP853 (rtol = atol = 1e-13) on the protocol's
    (x, pi) vector field (refimpl.fast, exponential chart; x stays well inside it), R = expm(ad x(t)).
    Error model: DOP853's global error at rtol 1e-13 over t = 0.5 with rates |Omega| ~ 1 is about
    1e-12; heyoka at tol 1e-15 adds less; 1e-9 is slack, far below the O(Upsilon |S|) ~ 1e-2 change
    that a transposed Psi or a dropped Theta would make."""
    p = bp.protocol_problem(name)
    n, T = p.n, 0.5
    F = Fast()

    def rhs(t, z):
        xd, pd = F.hamiltonian_vector_field(
            p.f, p.theta, p.upsilon, p.inertia, p.potential, z[:n], z[n:]
        )
        return np.concatenate([xd, pd])

    sol = solve_ivp(
        rhs, (0, T), np.concatenate([p.x0, p.pi0]), method="DOP853", rtol=1e-13, atol=1e-13
    )
    assert sol.success
    x, pi = sol.y[:n, -1], sol.y[n:, -1]
    ta = hy.taylor_adaptive(
        bp.heyoka_system(p.f, p.theta, p.upsilon, p.inertia, p.potential, p.pi0),
        p.y0(),
        tol=1e-15,
        compact_mode=True,
    )
    ta.propagate_until(T)
    err = bp.protocol_error(p, pi, expm(bp.ad_matrix(p.f, x)), ta.state)
    assert err <= 1e-9, err
    moved = np.max(np.abs(ta.state[:n] - p.pi0))
    assert moved > 1e-2  # the flow moved: the comparison is not of two starting states


def test_modified_su3_stays_away_from_the_degenerate_set():
    """Along the long-double reference trajectory min |Delta| stays far from 0 (the reference task
    samples 401 points); Delta = 1 at Upsilon = 0, and |Delta - 1| is O(|Upsilon| |S|)."""
    pytest.importorskip("heyoka")
    ref = bp.reference_task(("modified_su3", True))
    assert ref["min_abs_delta"] > 0.3
    assert ref["ld_vs_r128"] < 1e-14


@pytest.mark.slow
@pytest.mark.parametrize("name", bp.PROTOCOL_PROBLEMS)
def test_protocol_flow_vs_heyoka_at_equal_error(name):
    """The bench's measurement for one problem (T as in ``tstarg bench``): the protocol flow at its
    default accuracy against heyoka charged its cheapest quarter-decade tolerance at or below our
    error (CPU time, interleaved, best of repeats, JIT apart). Prints the ratio (issue 25's target:
    <= 1.0); asserts the rule was applied: every charged heyoka point is at least as accurate as ours.
    Run: ``python -m pytest -p no:cacheprovider -m slow tests/benchmarks/test_bench_protocol.py -s``."""
    ref = bp.reference_task((name, False))
    r = bp.measure_problem(name, False, ref, 7)
    o, b = r["ours"], r["heyoka_best"]
    print(
        f"\n{name}: ours {o['time'] * 1e3:.3f} ms, error {o['error']:.2e}; heyoka "
        + (
            f"{b['time'] * 1e3:.3f} ms at tol {b['tol']:.2e} "
            f"({'compact' if b['compact_mode'] else 'full'}), error {b['error']:.2e}; "
            f"ratio {r['ratio']:.3g}"
            if b
            else r["note"]
        )
    )
    assert np.isfinite(o["error"]) and o["time"] > 0
    assert all(h["error"] <= o["error"] for h in r["heyoka"])
