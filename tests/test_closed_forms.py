"""Closed forms: the elliptic free rigid body, DETEST B5, the separatrix, and heavy-top integrals,
all against the reference vector field (vier10, vier11) at high precision."""

from __future__ import annotations

import importlib.util

import mpmath
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tstarg.oracles import closed_forms as cf
from tstarg.properties.profiles import ref_examples
from tstarg.refimpl import su2
from tstarg.refimpl.reference import Reference

ZERO = [[0] * 3 for _ in range(3)]


def _ref_pidot(I, pi, dps=40):
    _xd, pd = Reference(dps).hamiltonian_vector_field_mp(
        su2(),
        ZERO,
        ZERO,
        [[I[i] if i == j else 0 for j in range(3)] for i in range(3)],
        None,
        [0, 0, 0],
        list(pi),
    )
    return pd


@settings(max_examples=ref_examples(0.3))
@given(
    I=st.permutations([1, 2, 3]).map(lambda p: [p[0], p[1] + 0.5, p[2] * 1.7]),
    pi0=st.tuples(*[st.floats(-2, 2).filter(lambda v: abs(v) > 0.05)] * 3),
    t=st.floats(0, 8),
)
def test_elliptic_solution_satisfies_reference_field(I, pi0, t):
    """d/dt of the Jacobi-elliptic closed form (mpmath.diff) equals the reference's dpi/dt to 30 digits."""
    with mpmath.workdps(50):
        sol = cf.rigid_body_solution(I, pi0)
        tt = mpmath.mpf(t)
        pi_t = sol(tt)
        d = [mpmath.diff(lambda s, i=i: sol(s)[i], tt) for i in range(3)]
        start = sol(0)
        assert max(abs(start[i] - mpmath.mpf(pi0[i])) for i in range(3)) < mpmath.mpf(10) ** -40
    pd = _ref_pidot(I, pi_t)
    with mpmath.workdps(50):
        err = max(abs(d[i] - pd[i]) for i in range(3))
        scale = max([mpmath.mpf(1)] + [abs(v) for v in pd])
    # error model: 40-digit reference and 50-digit closed form: 10^-30 relative leaves 10 digits slack
    assert err <= mpmath.mpf(10) ** -30 * scale


def test_detest_b5_matches_published():
    """Our elliptic solution through y(0) = (0, 1, 1), rescaled, is the published (sn, cn, dn)(x | 0.51)."""
    with mpmath.workdps(50):
        inertia, s, p0 = cf.detest_b5()
        sol = cf.rigid_body_solution(inertia, p0)
        assert abs(sol.m - mpmath.mpf(51) / 100) < mpmath.mpf(10) ** -45
        for x in [mpmath.mpf(k) / 4 for k in range(49)]:
            y = [s[i] * sol(x)[i] for i in range(3)]
            e = cf.detest_b5_exact(x)
            assert max(abs(y[i] - e[i]) for i in range(3)) < mpmath.mpf(10) ** -40


def test_detest_b5_is_the_published_ode():
    """(sn, cn, dn)(x | 0.51) solves y1' = y2 y3, y2' = -y1 y3, y3' = -0.51 y1 y2 (mpmath.diff, 40 digits)."""
    with mpmath.workdps(50):
        for x in (mpmath.mpf("0.3"), mpmath.mpf("4.1"), mpmath.mpf(17)):
            y = cf.detest_b5_exact(x)
            d = [mpmath.diff(lambda s, i=i: cf.detest_b5_exact(s)[i], x) for i in range(3)]
            rhs = [y[1] * y[2], -y[0] * y[2], -cf.DETEST_B5_M() * y[0] * y[1]]
            assert max(abs(d[i] - rhs[i]) for i in range(3)) < mpmath.mpf(10) ** -40


def test_separatrix_is_sech_tanh():
    """On the separatrix (2 E I_2 = |pi|^2) m = 1 and pi = (A sech, B tanh, C sech) in the dn/cn/sn slots;
    pi tends to the unstable middle-axis rotation."""
    with mpmath.workdps(50):
        I = [mpmath.mpf(1), mpmath.mpf(2), mpmath.mpf(3)]
        p3 = mpmath.mpf("0.4")
        p1 = p3 * mpmath.sqrt((1 / I[1] - 1 / I[2]) / (1 / I[0] - 1 / I[1]))
        pi0 = [p1, mpmath.mpf("0.2"), p3]
        E2 = sum(pi0[i] ** 2 / I[i] for i in range(3))
        M2 = sum(v**2 for v in pi0)
        assert abs(E2 * I[1] - M2) < mpmath.mpf(10) ** -45
        sol = cf.rigid_body_solution(I, pi0)
        assert sol.m == 1
        p, q, r = sol.perm
        assert q == 1
        for t in (mpmath.mpf(1), mpmath.mpf(7)):
            tau = sol.w * t + sol.u0
            val = sol(t)
            assert abs(val[p] - sol.A * mpmath.sech(tau)) < mpmath.mpf(10) ** -40
            assert abs(val[q] - sol.B * mpmath.tanh(tau)) < mpmath.mpf(10) ** -40
            assert abs(val[r] - sol.C * mpmath.sech(tau)) < mpmath.mpf(10) ** -40
        assert (
            abs(abs(sol.B) - mpmath.sqrt(M2)) < mpmath.mpf(10) ** -40
        )  # tanh -> 1: pi -> (0, +-|pi|, 0)
        far = sol(mpmath.mpf(400))
        assert abs(abs(far[1]) - mpmath.sqrt(M2)) < mpmath.mpf(10) ** -20


def test_rigid_body_solution_rejects_bad_input():
    """Equal moments, non-positive moments and equilibria are rejected with a ValueError."""
    with pytest.raises(ValueError, match="distinct"):
        cf.rigid_body_solution([1, 1, 2], [0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="positive"):
        cf.rigid_body_solution([1, -1, 2], [0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="principal axis"):
        cf.rigid_body_solution([1, 2, 3], [0, 0, 0.3])


STATES = [
    (["0.2", "0.5", "-0.3"], ["0.3", "-0.7", "0.4"]),
    (["-1.1", "0.4", "0.9"], ["1.5", "0.2", "-0.6"]),
]


def _on_gc_level(x, pi):
    ref = Reference(60)
    with ref._prec():
        F = ref._algebra_mp(su2())
        G = mpmath.expm(ref.ad(F, mpmath.matrix([mpmath.mpf(v) for v in x]))).T * mpmath.matrix(
            [0, 0, 1]
        )
        pv = mpmath.matrix([mpmath.mpf(v) for v in pi])
        pv = pv - (pv.T * G)[0] / (G.T * G)[0] * G
        return [pv[i] for i in range(3)]


@pytest.mark.parametrize("top", list(cf.HEAVY_TOPS))
@pytest.mark.parametrize("state", range(len(STATES)))
def test_heavy_top_integrals_conserved(top, state):
    """Energy, Casimirs and the Lagrange / Kovalevskaya / Goryachev-Chaplygin integral have dI/dt = 0 along
    the reference vector field (50 digits; dGamma/dt by the chain rule)."""
    x, pi = STATES[state]
    if top == "goryachev_chaplygin":
        pi = _on_gc_level(x, pi)
    rates = cf.integral_rates(top, x, pi, dps=50)
    assert top in rates
    with mpmath.workdps(60):
        for name, (rate, scale) in rates.items():
            # error model: 50-digit evaluation, mpmath.diff of Gamma: 10^-40 |grad I| |zdot|
            assert abs(rate) <= mpmath.mpf(10) ** -40 * max(1, scale), (name, rate, scale)


def test_heavy_top_negative_controls():
    """The checks can fail: the Kovalevskaya integral with the opposite constant, and Goryachev-Chaplygin off pi.Gamma = 0,
    are not conserved (rate of the order of |grad I| |zdot|)."""
    import sympy as sp

    x, pi = STATES[0]
    rates = cf.integral_rates("goryachev_chaplygin", x, pi, dps=50)
    rate, scale = rates["goryachev_chaplygin"]
    assert abs(rate) > mpmath.mpf(10) ** -3 * scale
    orig = cf.heavy_top_integrals

    def wrong(inertia, L):
        out = orig(inertia, L)
        if "kovalevskaya" in out:
            G, p = cf._sym()
            Om = [p[i] / sp.nsimplify(inertia[i]) for i in range(3)]
            c = -sp.nsimplify(L[0]) / sp.nsimplify(inertia[2])
            out["kovalevskaya"] = (
                (Om[0] ** 2 - Om[1] ** 2 + c * G[0]) ** 2 + (2 * Om[0] * Om[1] + c * G[1]) ** 2,
                False,
            )
        return out

    cf.heavy_top_integrals = wrong
    try:
        rate, scale = cf.integral_rates("kovalevskaya", x, pi, dps=50)["kovalevskaya"]
    finally:
        cf.heavy_top_integrals = orig
    assert abs(rate) > mpmath.mpf(10) ** -3 * scale


@pytest.mark.slow
@pytest.mark.skipif(
    importlib.util.find_spec("tstarg.refimpl.flows") is None, reason="refimpl.flows not available"
)
def test_reference_flow_matches_elliptic_closed_form():
    """The reference flow (refimpl.flows) of the free rigid body agrees with the Jacobi-elliptic closed form."""
    from tstarg.refimpl.flows import reference_flow

    I, pi0, T = [1, 2, 3], ["0.3", "0.9", "-0.5"], 2
    _x, pi = reference_flow(
        su2(), ZERO, ZERO, [[1, 0, 0], [0, 2, 0], [0, 0, 3]], None, [0, 0, 0], pi0, T
    )
    with mpmath.workdps(40):
        sol = cf.rigid_body_solution(I, [mpmath.mpf(v) for v in pi0])
        ex = sol(mpmath.mpf(T))
        assert max(abs(mpmath.mpf(pi[i]) - ex[i]) for i in range(3)) < mpmath.mpf(10) ** -20


@pytest.mark.slow
@pytest.mark.skipif(
    importlib.util.find_spec("tstarg.refimpl.flows") is None, reason="refimpl.flows not available"
)
@pytest.mark.parametrize("top", list(cf.HEAVY_TOPS))
def test_heavy_top_integrals_along_reference_flow(top):
    """Each integral of the top takes the same value at t = 0 and t = 1 along refimpl.flows.reference_flow."""
    import sympy as sp

    from tstarg.refimpl.flows import reference_flow

    spec = cf.HEAVY_TOPS[top]
    x0, pi0 = STATES[0]
    if top == "goryachev_chaplygin":
        pi0 = _on_gc_level(x0, pi0)
    inertia = [[spec["inertia"][i] if i == j else 0 for j in range(3)] for i in range(3)]
    pot = {"kind": "gravity", "L": list(spec["L"]), "gamma": list(spec["gamma"])}
    x1, pi1 = reference_flow(su2(), ZERO, ZERO, inertia, pot, x0, pi0, 1, dps=30)
    ref = Reference(40)
    G, p = cf._sym()
    with ref._prec():
        F = ref._algebra_mp(su2())
        gam = mpmath.matrix(list(spec["gamma"]))

        def state(x, pi):
            xv = mpmath.matrix([mpmath.mpf(v) for v in x])
            Gv = mpmath.expm(ref.ad(F, xv)).T * gam
            return list(Gv) + [mpmath.mpf(v) for v in pi]

        z0, z1 = state(x0, pi0), state(x1, pi1)
        for name, (expr, _needs) in cf.heavy_top_integrals(spec["inertia"], spec["L"]).items():
            fn = sp.lambdify(list(G) + list(p), expr, modules="mpmath")
            a, b = fn(*z0), fn(*z1)
            # error model: 30-digit flow with local tolerance 10^-35: 10^-22 max(1, |I|)
            assert abs(a - b) <= mpmath.mpf(10) ** -22 * max(1, abs(a)), (name, a, b)


def test_published_betti_numbers():
    """b1 = dim g - dim [g, g] (refimpl) equals the published table; with the published b2, class A
    3-dimensional algebras satisfy b2 = b1 and class B b2 = b1 - 1 (Poincare duality / Euler characteristic)."""
    from tstarg.oracles.published import PUBLISHED_B1, PUBLISHED_H2
    from tstarg.refimpl import CATALOGUE_NAMES, catalogue

    assert set(PUBLISHED_B1) == set(CATALOGUE_NAMES)
    for name in CATALOGUE_NAMES:
        alg = catalogue(name)
        assert alg.dim - alg.derived_dim() == PUBLISHED_B1[name], name
        if name.startswith("Bianchi"):
            expected = PUBLISHED_B1[name] - (0 if alg.is_unimodular() else 1)
            assert PUBLISHED_H2[name] == expected, name
