"""The reference flow (mpmath): closed forms, conservation laws, and agreement of its own routes.

Properties: the free rigid body matches the Jacobi-elliptic closed form; the
heavy top keeps energy and both Casimirs; the full state (x, pi) flow with
re-basing reproduces the reduced Euler-Poisson flow; the precision ladder agrees.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from tests._helpers import mp_digits
from tstarg.refimpl import su2
from tstarg.refimpl.flows import euler_top_closed_form, reference_flow, reference_trajectory

Z = np.zeros((3, 3), dtype=object)
Z[...] = 0
I123 = [[1, 0, 0], [0, 2, 0], [0, 0, 3]]
TOP_I = [[1, 0, 0], [0, 1, 0], [0, 0, "1/2"]]  # Lagrange top: I1 = I2
GRAV = {"kind": "gravity", "L": [0, 0, 1], "gamma": [0, 0, -1]}


@pytest.mark.parametrize("pi0", [["0.4", "-0.3", "1.1"], ["-0.7", "0.5", "-1.3"]])
def test_free_rigid_body_matches_jacobi_elliptic_closed_form(pi0):
    """Reference free rigid body == closed form in mpmath.ellipfun to >= 30 digits at t = 50."""
    tr = reference_trajectory(su2(), Z, Z, I123, None, [0, 0, 0], pi0, [50], dps=40, system="body")
    with mpmath.workdps(70):
        closed = euler_top_closed_form([1, 2, 3], [mpmath.mpf(v) for v in pi0], 50)
    assert mp_digits(tr.pi[-1], closed) >= 30


def test_closed_form_solves_euler_equations():
    """The closed form itself obeys dpi/dt = pi x Omega (checked by mpmath.diff at 40 digits)."""
    with mpmath.workdps(40):
        pi0 = [mpmath.mpf("0.4"), mpmath.mpf("-0.3"), mpmath.mpf("1.1")]
        t = mpmath.mpf("1.7")
        p = euler_top_closed_form([1, 2, 3], pi0, t)
        dp = [
            mpmath.diff(lambda s, i=i: euler_top_closed_form([1, 2, 3], pi0, s)[i], t)
            for i in range(3)
        ]
        W = [p[0] / 1, p[1] / 2, p[2] / 3]
        cross = [p[1] * W[2] - p[2] * W[1], p[2] * W[0] - p[0] * W[2], p[0] * W[1] - p[1] * W[0]]
        assert mp_digits(dp, cross, dps=40) >= 30
        assert mp_digits(euler_top_closed_form([1, 2, 3], pi0, 0), pi0, dps=40) >= 35


def _heavy_top_invariants(tr):
    out = []
    for pi, G in zip(tr.pi, tr.Gamma):
        E = (pi[0] ** 2 + pi[1] ** 2) / 2 + pi[2] ** 2 - G[2]  # I^-1 = diag(1, 1, 2), L = e3
        out.append([E, sum(g * g for g in G), sum(p * g for p, g in zip(pi, G))])
    return out


def _assert_conserved(tr, digits):
    assert tr.times[0] == 0  # compare with the exact initial values
    with mpmath.workdps(tr.dps + 10):
        inv = _heavy_top_invariants(tr)
        for k, name in enumerate(("energy", "|Gamma|^2", "pi.Gamma")):
            worst = max(abs(row[k] - inv[0][k]) / max(1, abs(inv[0][k])) for row in inv)
            got = float("inf") if worst == 0 else float(-mpmath.log10(worst))
            assert got >= digits, f"{name}: conserved to {got:.1f} digits, need {digits}"


def test_heavy_top_conserves_energy_and_casimirs_short():
    """Heavy top (Euler-Poisson): energy, |Gamma|^2, pi.Gamma conserved to >= 28 digits over t = 10 (dps 30)."""
    tr = reference_trajectory(
        su2(),
        Z,
        Z,
        TOP_I,
        GRAV,
        ["0.1", "0.2", "0"],
        ["0.3", "0.2", "2"],
        [0, 2, 5, 10],
        dps=30,
        system="body",
    )
    _assert_conserved(tr, 28)


@pytest.mark.slow
def test_heavy_top_conserves_energy_and_casimirs_t100():
    """Heavy top: energy and both Casimirs conserved to >= 30 digits over t = 100 (dps 40)."""
    tr = reference_trajectory(
        su2(),
        Z,
        Z,
        TOP_I,
        GRAV,
        ["0.1", "0.2", "0"],
        ["0.3", "0.2", "2"],
        [0, 25, 50, 75, 100],
        dps=40,
        system="body",
    )
    _assert_conserved(tr, 30)


def test_precision_ladder_agrees():
    """The run at dps and at dps + 15 (tolerance 10^-10 smaller) agree to >= dps - 3 digits."""
    tr = reference_trajectory(
        su2(),
        Z,
        Z,
        TOP_I,
        GRAV,
        ["0.1", "0.2", "0"],
        ["0.3", "0.2", "2"],
        [3],
        dps=25,
        system="body",
        check=True,
    )
    assert tr.digits >= 22


def test_full_state_flow_with_rebasing_matches_reduced_flow():
    """(x, pi) flow of vier10/vier11 re-based through g_ref: pi and Gamma = Ad(g)^T gamma equal the
    Euler-Poisson flow of (pi, Gamma) (twee17 corrected, twee18), and g stays in SU(2)."""
    x0, pi0 = ["0.5", "0.6", "0.3"], ["0.3", "0.2", "2"]
    full = reference_trajectory(
        su2(), Z, Z, TOP_I, GRAV, x0, pi0, ["0.5", "1"], dps=20, system="full"
    )
    body = reference_trajectory(
        su2(), Z, Z, TOP_I, GRAV, x0, pi0, ["0.5", "1"], dps=20, system="body"
    )
    assert full.rebases >= 1
    assert mp_digits(full.pi, body.pi) >= 18
    assert mp_digits(full.Gamma, body.Gamma) >= 18
    with mpmath.workdps(30):
        g = mpmath.matrix(full.g[-1].tolist())
        unit = g * g.transpose_conj() - mpmath.eye(2)
        assert mpmath.mnorm(unit, 1) < mpmath.mpf(10) ** -18
        assert abs(mpmath.det(g) - 1) < mpmath.mpf(10) ** -18
        # x reported through the representation: exp(x^a E_a) == g
        X = sum(
            (mpmath.mpf(full.x[-1][a]) * mpmath.matrix(su2().rep[a].tolist()) for a in range(3)),
            mpmath.zeros(2, 2),
        )
        assert mpmath.mnorm(mpmath.expm(X) - g, 1) < mpmath.mpf(10) ** -18


def test_reference_flow_protocol_shape_and_zero_time():
    """Protocol flow: t = 0 returns the initial state; float inputs give float64 arrays of shape (n,)."""
    f = su2().f
    x, pi = reference_flow(
        f,
        np.zeros((3, 3)),
        np.zeros((3, 3)),
        np.eye(3),
        None,
        np.array([0.1, 0.2, 0.3]),
        np.array([1.0, 0.5, 0.2]),
        0.0,
        dps=20,
    )
    assert x.dtype == float and x.shape == (3,)
    assert np.array_equal(x, [0.1, 0.2, 0.3]) and np.array_equal(pi, [1.0, 0.5, 0.2])
