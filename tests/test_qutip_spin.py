"""qutip's spin picture: pi <-> -J - xi reproduces the Lie-Poisson bracket (twee9, drie3) and its flows."""

from __future__ import annotations

import numpy as np
import pytest

from tstarg.oracles import qutip_spin as qs

EPS = np.finfo(float).eps
JS = [0.5, 1, 1.5, 2, 3, 5, 10]


@pytest.mark.parametrize("j", JS)
def test_commutators_match_lie_poisson(j):
    """[P_a, P_b] = i {pi_a, pi_b} = -i (P_k + xi_k) eps_kab for P = -J - xi; the sign P = +J fails by O(j)."""
    xi = (0.2, -0.1, 0.4)
    # error model: entries of J are O(j) sums of O(1) float products: 16 eps j^2
    assert qs.commutator_defect(j, xi) <= 16 * EPS * max(1.0, j) ** 2
    assert qs.commutator_defect(j, xi, sign=1) >= 0.5 * j


@pytest.mark.parametrize("j", JS + [20])
def test_linear_hamiltonian_exact_for_every_j(j):
    """H = b.pi with the Theta shift: <P>(t) follows the classical rotation of pi' = pi + xi exactly."""
    times = np.linspace(0, 5, 6)
    b = (0.3, -0.5, 0.8)
    err, scale = qs.linear_flow_error(j, b, (0.2, 0.1, -0.3), times)
    # error model: dense expm of a (2j+1)-dim Hermitian H, ||H|| ~ |b| j: 64 eps (2j+1) |b| t_max scale
    tol = 64 * EPS * (2 * j + 1) * np.linalg.norm(b) * times[-1] * max(1.0, scale)
    assert err <= tol and err <= 1e-10, (err, tol)


def test_linear_hamiltonian_wrong_sign_fails():
    """Control: with pi <-> +J the classical flow runs backwards and the comparison fails."""
    times = np.linspace(0, 2, 3)
    import qutip

    j, b = 2, np.array([0.3, -0.5, 0.8])
    P = [qutip.jmat(j, k) for k in "xyz"]  # wrong sign
    H = sum(b[a] * P[a] for a in range(3))
    psi0 = qutip.spin_coherent(j, 0.7, 0.3)
    pi0 = np.array([qutip.expect(p, psi0) for p in P])
    psi = (-1j * H * times[-1]).expm() * psi0
    q = np.array([qutip.expect(p, psi) for p in P])
    from scipy.linalg import expm

    cl = expm(-times[-1] * qs._cross_matrix(b)) @ pi0
    assert np.max(np.abs(q - cl)) > 0.1


def _exponent(js):
    ts = np.linspace(0, 2, 5)
    errs = []
    for j in js:
        q, c = qs.rigid_body_expectation(j, (1.0, 2.0, 3.0), ts)
        errs.append(np.max(np.abs(q[-1] - c[-1])))
    return float(np.polyfit(np.log(js), np.log(errs), 1)[0]), errs


def test_rigid_body_coherent_error_falls_like_one_over_j():
    """Free rigid body from a coherent state: |<P>/j - pi_cl| at t = 2 falls like j^-1 (exponent within 0.1)."""
    slope, errs = _exponent([4, 8, 16, 32])
    assert abs(slope + 1) <= 0.1, (slope, errs)


@pytest.mark.slow
def test_rigid_body_one_over_j_large_j():
    """The 1/j law continues to j = 256."""
    slope, errs = _exponent([16, 32, 64, 128, 256])
    assert abs(slope + 1) <= 0.1, (slope, errs)


def test_attitude_spin_half_and_spin_one():
    """g(t) from qutip's propagator of -Omega(t).J (spin 1/2) matches dg/dt = g Omega integrated by DOP853,
    and the spin-1 propagator represents the same group element (U J_b U^-1 = Ad(g)^m_b J_m)."""
    I, pi0, T = (1.0, 2.0, 3.0), (0.3, 0.9, -0.5), 3.0
    g_half = qs.attitude_propagator(0.5, I, pi0, T).full()
    g_cl = qs.attitude_classical(I, pi0, T)
    # both integrate at rtol 1e-13 over T = 3, |Omega| ~ 1: global error ~1e-12, bar 1e-10
    assert np.max(np.abs(g_half - g_cl)) <= 1e-10
    assert abs(np.linalg.det(g_cl) - 1) <= 1e-10
    U1 = qs.attitude_propagator(1, I, pi0, T)
    assert qs.rep_defect(U1, qs.adjoint_from_spin_half(g_cl)) <= 1e-10
    # control: the other ordering (g' = Omega g) is a different element
    assert np.max(np.abs(g_half - qs.attitude_propagator(0.5, I, pi0, T).dag().full())) > 1e-3


def test_spatial_momentum_conserved_by_quantum_attitude():
    """pi^R = Ad(g^-1)^T pi (twee3) is constant along the free motion, with g from qutip's spin-1/2 propagator."""
    import mpmath

    from tstarg.oracles.closed_forms import rigid_body_solution

    I, pi0 = (1.0, 2.0, 3.0), (0.3, 0.9, -0.5)
    with mpmath.workdps(30):
        sol = rigid_body_solution(I, pi0)
        piT = np.array([float(v) for v in sol(mpmath.mpf(3))])
    g = qs.attitude_propagator(0.5, I, pi0, 3.0).full()
    Ad = qs.adjoint_from_spin_half(g)
    piR = np.linalg.inv(Ad).T @ piT
    assert np.max(np.abs(piR - np.array(pi0))) <= 1e-10


def test_bad_j():
    """A spin that is not a positive half-integer is rejected."""
    with pytest.raises(ValueError, match="half-integer"):
        qs.momentum_operators(0.3)
