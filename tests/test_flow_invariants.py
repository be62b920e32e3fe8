"""Invariants along trajectories: momentum map of the left action, Casimirs, energy.

J(g, pi) = K(g) pi - A(x)^T Theta x (refimpl.flows docstring: derived from
i_X omega_I = dJ with the right-invariant generator of the left action) is
conserved when V = 0, for any Upsilon; Casimirs |Gamma|^2, pi'.Gamma (or |pi'|^2)
are kept by the Poisson integrators to rounding; energy drift is reported per method.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from tests._helpers import mp_digits
from tstarg.refimpl import catalogue, coboundary_basis, cocycle_basis, su2
from tstarg.refimpl.flows import (
    METHODS,
    NumpyModel,
    casimirs,
    energy,
    integrate_fast,
    momentum_map,
    reference_trajectory,
)

EPS = np.finfo(float).eps


def _nontrivial_cocycle(alg):
    """A cocycle outside B^2 (non-trivial class), from the cocycle and coboundary bases."""
    B = [np.asarray(b, dtype=float).ravel() for b in coboundary_basis(alg, exact=False)]
    for z in cocycle_basis(alg, exact=False):
        zf = np.asarray(z, dtype=float)
        M = np.array(B + [zf.ravel()]).T if B else zf.ravel()[:, None]
        if np.linalg.matrix_rank(M, tol=1e-10) > len(B):
            return zf
    raise AssertionError("no non-trivial cocycle")


def _J_drift(tr, ref_J):
    with mpmath.workdps(tr.dps):
        return min(mp_digits(row, ref_J, dps=tr.dps) for row in tr.J)


def test_momentum_map_conserved_su2_with_cocycle_and_rebasing():
    """V = 0, su(2), Theta = -xi.f, Upsilon != 0: J = K(g) pi - A^T Theta x conserved (>= 17 digits at dps 20)
    across re-basings; the same formula with the cocycle term's sign flipped is not conserved."""
    alg = su2()
    xi = np.array([0.3, -0.2, 0.5])
    theta = -np.einsum("k,kab->ab", xi, alg.f)
    ups = np.einsum("l,lmn->mn", np.array([0.05, -0.04, 0.03]), alg.f)
    x0, pi0 = np.array([0.4, -0.3, 0.2]), np.array([0.7, 0.4, 1.2])
    tr = reference_trajectory(
        alg, theta, ups, np.diag([1.0, 2.0, 3.0]), None, x0, pi0, [0, 1, 2, 3], dps=20
    )
    assert tr.rebases >= 1
    J0 = momentum_map(alg, theta, x0, pi0, dps=40)
    assert _J_drift(tr, list(J0)) >= 17
    # negative control: K(g) pi + A^T Theta x drifts at O(1)
    with mpmath.workdps(30):
        wrong0 = np.asarray(momentum_map(alg, -theta, x0, pi0), dtype=float)
    x1 = np.array([float(v) for v in tr.x[1]])
    pi1 = np.array([float(v) for v in tr.pi[1]])
    wrong1 = momentum_map(alg, -theta, x1, pi1)
    assert np.max(np.abs(wrong1 - wrong0)) > 1e-3


def test_momentum_map_coboundary_form():
    """For Theta = -xi.f: K(g) pi - A^T Theta x == K(g)(pi + xi) - xi (drie7 transported), float64."""
    alg = su2()
    xi = np.array([0.3, -0.2, 0.5])
    theta = -np.einsum("k,kab->ab", xi, alg.f)
    from tstarg.refimpl import frames

    x, pi = np.array([1.1, -0.7, 0.4]), np.array([0.2, -0.9, 1.3])
    J = momentum_map(alg, theta, x, pi)
    K = frames(alg, x)["K"]
    # error model: a few products of O(1) matrices and vectors: 32 n eps * |pi'|
    assert np.max(np.abs(J - (K @ (pi + xi) - xi))) <= 32 * 3 * EPS * np.linalg.norm(pi + xi)


def test_momentum_map_conserved_heisenberg_nontrivial_cocycle():
    """h(3) with a cocycle not in B^2 and Upsilon != 0, V = 0: J is conserved (>= 17 digits at dps 20)."""
    alg = catalogue("h(3)")
    theta = 0.7 * _nontrivial_cocycle(alg)
    ups = np.zeros((3, 3))
    ups[0, 1], ups[1, 0] = 0.2, -0.2
    x0, pi0 = np.array([0.3, -0.2, 0.1]), np.array([0.5, 0.4, 0.3])
    tr = reference_trajectory(
        alg, theta, ups, np.diag([1.0, 1.5, 2.0]), None, x0, pi0, [0, 1, 2], dps=20
    )
    J0 = momentum_map(alg, theta, x0, pi0, dps=40)
    assert _J_drift(tr, list(J0)) >= 17


HEAVY = dict(L=np.array([0.1, 0.0, 1.0]), gamma=np.array([0.0, 0.0, -1.0]))


@pytest.mark.parametrize("name", ["splitting2", "splitting4", "midpoint", "gauss4"])
def test_casimirs_kept_to_rounding_by_poisson_integrators(name):
    """Splittings (Poisson maps) and Gauss methods (quadratic invariants): |Gamma|^2 and pi'.Gamma
    drift at rounding level over 2000 steps, for 50 trajectories of a gyrostat heavy top."""
    alg = su2()
    xi = np.array([0.2, -0.1, 0.3])
    theta = -np.einsum("k,kab->ab", xi, alg.f)
    pot = {"kind": "gravity", **HEAVY}
    model = NumpyModel(alg, theta, np.zeros((3, 3)), np.diag([1.0, 1.3, 0.5]), pot)
    rng = np.random.default_rng(7)
    pi0 = rng.normal(size=(3, 50))
    x0 = rng.normal(size=(3, 50)) * 0.5
    rec = []
    integrate_fast(
        model,
        METHODS[name],
        x0,
        pi0,
        100.0,
        2000,
        system="body",
        observe=lambda k, p, G, x: (
            rec.append(casimirs(alg.f, theta, p.T, G.T)) if k % 500 == 0 else None
        ),
    )
    nsteps = 2000
    for key in rec[0]:
        vals = np.array([r[key] for r in rec])
        drift = np.max(np.abs(vals - vals[0]), axis=0)
        scale = np.max(np.abs(vals), axis=0) + 1.0
        # error model: rounding per step ~ 16 eps * scale (rotations / stage sums; Gauss fixed point to
        # 4 eps), accumulating at most linearly over the steps
        assert np.all(drift <= 16 * nsteps * EPS * scale), (key, drift.max())


def test_energy_drift_report_per_method():
    """Energy drift per method on the heavy top (t = 20): the symplectic splitting's drift stays bounded
    (no growth between t = 10 and t = 20 beyond 2x) while all methods agree on H(0)."""
    alg = su2()
    pot = {"kind": "gravity", **HEAVY}
    I = np.diag([1.0, 1.3, 0.5])
    model = NumpyModel(alg, np.zeros((3, 3)), np.zeros((3, 3)), I, pot)
    x0, pi0 = np.array([[0.1], [0.2], [0.0]]), np.array([[0.3], [0.2], [1.5]])
    report = {}
    for name in ("splitting2", "dop853", "gauss4"):
        Hs = []
        integrate_fast(
            model,
            METHODS[name],
            x0,
            pi0,
            20.0,
            400,
            system="body",
            observe=lambda k, p, G, x: Hs.append(energy(I, pot, p.T, G.T)[0]),
        )
        Hs = np.array(Hs)
        H0 = energy(I, pot, pi0.T, (np.array([[0.0, 0.0, -1.0]]) @ np.eye(3)))[0]
        report[name] = (np.max(np.abs(Hs[:200] - H0)), np.max(np.abs(Hs - H0)))
    d1, d2 = report["splitting2"]
    assert (
        d2 <= 2 * d1 + 1e3 * EPS
    )  # bounded oscillation, not secular growth (rounding slack 1e3 eps)
    assert report["dop853"][1] < report["splitting2"][1]
