"""Long flows (issue 13): the heavy top and a modified top (Theta, Upsilon != 0) to T = 1000 with both
implementations, full state (x, pi) re-based through the representation; drift of the energy, the
Casimirs and the conserved momentum-map component. All marked slow.

Conserved quantities (independent of the integrators): ``H`` (twee10, twee15); for the heavy top
``|Gamma|^2``, ``pi.Gamma`` (twee17/18) and ``gamma.J`` (the left action about the gravity axis leaves
``V`` invariant); for the modified top with ``V = 0`` the Casimir ``|pi + xi|^2`` (drie7) and every
component of ``J = K(g)(pi + xi) - xi`` (module docstring of refimpl.flows; the Upsilon term is
left-invariant and vertical, so it does not change the momentum map).
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from tstarg.refimpl._catalogue import su2
from tstarg.refimpl._flow_reference import reference_trajectory
from tstarg.refimpl._invariants import momentum_map
from tstarg.refimpl.flows import fast_trajectory

pytestmark = pytest.mark.slow
EPS = np.finfo(float).eps
T_END = 1000.0
EPS3 = np.zeros((3, 3, 3))
for _i, _j, _k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
    EPS3[_k, _i, _j], EPS3[_k, _j, _i] = 1.0, -1.0


def heavy_top():
    I = np.diag([1.0, 1.5, 2.5])
    pot = {"kind": "gravity", "L": np.array([0.0, 0.1, 0.5]), "gamma": np.array([0.0, 0.0, 1.0])}
    return (
        su2(),
        np.zeros((3, 3)),
        np.zeros((3, 3)),
        I,
        pot,
        np.array([0.3, -0.2, 0.1]),
        np.array([0.8, 0.4, 1.5]),
    )


def modified_top():
    xi, tau = np.array([0.2, -0.1, 0.3]), np.array([0.1, 0.05, -0.08])
    theta = -np.einsum("k,kab->ab", xi, EPS3)  # Theta_ab = -xi_k eps_kab (coboundary, zeven3)
    ups = np.einsum("l,lmn->mn", tau, EPS3)  # Upsilon^mn = tau_l eps_lmn
    I = np.diag([1.0, 1.5, 2.5])
    return su2(), theta, ups, I, None, np.array([0.3, -0.2, 0.1]), np.array([0.8, 0.4, 1.5])


MODELS = {"heavy top": heavy_top, "modified top": modified_top}


def invariants(name, model, x, pi, Gamma):
    """(T, k) array of the conserved quantities along samples x, pi (T, 3)."""
    alg, theta, _ups, I, pot, _, _ = model
    Iinv = np.linalg.inv(I)
    rows = []
    for k in range(len(pi)):
        p = np.asarray(pi[k], dtype=float)
        xk = np.asarray(x[k], dtype=float)
        J = momentum_map(alg.f, theta, xk, p)
        if name == "heavy top":
            G = np.asarray(Gamma[k], dtype=float)
            H = p @ Iinv @ p / 2 - G @ pot["L"]
            rows.append([H, G @ G, p @ G, pot["gamma"] @ J])
        else:
            q = p + np.array([-theta[1, 2], -theta[2, 0], -theta[0, 1]])  # pi' = pi + xi
            rows.append([p @ Iinv @ p / 2, q @ q, *J])
    return np.array(rows)


def _report(tag, inv):
    drift = np.max(np.abs(inv - inv[0]), axis=0)
    print(f"{tag}: drift per invariant {np.array2string(drift, precision=2)}")
    return drift


@pytest.mark.parametrize("name", list(MODELS))
def test_fast_long_flow(name):
    """dop853 / gauss6 with h = 0.1 (10000 steps): every drift within the error model
    ``10 |Q_h - Q_2h| + 10^3 eps sqrt(steps) scale`` (truncation estimated by halving the step,
    rounding as a random walk)."""
    model = MODELS[name]()
    runs = {}
    for sps in (100, 200):  # h = 0.1 and 0.05
        tr = fast_trajectory(*model, T_END, 51, sps)
        runs[sps] = invariants(
            name,
            model,
            tr["x"][:, 0],
            tr["pi"][:, 0],
            None if tr["Gamma"] is None else tr["Gamma"][:, 0],
        )
        assert np.all(np.isfinite(tr["x"])) and tr["g"] is not None
    fine, coarse = runs[200], runs[100]
    drift = _report(f"fast {name}", fine)
    scale = np.maximum(1.0, np.max(np.abs(fine), axis=0))
    bound = 10 * np.max(np.abs(fine - coarse), axis=0) + 1e3 * EPS * np.sqrt(50 * 200) * scale
    assert np.all(drift <= bound), (drift, bound)


@pytest.mark.parametrize("name", list(MODELS))
def test_reference_long_flow(name):
    """The reference at dps 15 (local tolerance 10^-20 at 30 digits) to T = 1000: drift below
    ``10^-11`` relative (about 10^4 steps, each within 10^-20, times a growth cushion of 10^5)."""
    model = MODELS[name]()
    times = [0, 250, 500, 750, 1000]
    tr = reference_trajectory(*model, times, dps=15)
    inv = invariants(name, model, tr.x, tr.pi, tr.Gamma)
    assert all(mpmath.isfinite(v) for v in tr.x.ravel())
    drift = _report(f"reference {name}", inv)
    scale = np.maximum(1.0, np.max(np.abs(inv), axis=0))
    assert np.all(drift <= 1e-11 * scale), drift


@pytest.mark.parametrize("name", list(MODELS))
def test_reference_cost_per_unit_time_stays_flat(name, monkeypatch):
    """Re-basing keeps the chart small, so the work per unit of time does not grow with T: accepted
    GBS steps (a deterministic work count; CPU time printed, not asserted) per unit time on (10, 100]
    at most 1.5 times that on (1, 10], with the flow re-based along the way."""
    import time

    from tstarg.refimpl import _flow_reference

    orig = _flow_reference.gbs_mp
    log = []
    t0 = time.process_time()

    def counted(F, y, t_end, **kw):
        res = orig(F, y, t_end, **kw)
        log.append((float(t_end), res.steps, time.process_time() - t0))
        return res

    monkeypatch.setattr(_flow_reference, "gbs_mp", counted)
    model = MODELS[name]()
    tr = reference_trajectory(*model, [1, 10, 100], dps=15)
    (t1, s1, c1), (t10, s10, c10), (t100, s100, c100) = log
    rate_10, rate_100 = s10 / (t10 - t1), s100 / (t100 - t10)
    print(
        f"reference {name} dps 15: steps/unit {s1 / t1:.2f} {rate_10:.2f} {rate_100:.2f}; "
        f"CPU s/unit {c1 / t1:.2f} {(c10 - c1) / (t10 - t1):.2f} {(c100 - c10) / (t100 - t10):.2f}; "
        f"rebases {tr.rebases}"
    )
    assert rate_100 <= 1.5 * rate_10
    assert tr.rebases >= 10  # the flow did leave the first chart and was re-based
