"""The fast float64 implementation agrees with the mpmath reference within its per-point error
model, error_bound = C_P n eps cond(Phi) frame_cond max|P| (refimpl.fast), on every catalogue
algebra and in every conditioning regime; degenerate points are flagged, never dropped."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tests._helpers import assert_within_bound, regime_cases
from tstarg.properties import REGIMES, cocycles, points, upsilons
from tstarg.properties.profiles import ref_examples
from tstarg.refimpl import catalogue, su2
from tstarg.refimpl._fast_kernels import _generic_poisson
from tstarg.refimpl.fast import implementation as fast
from tstarg.refimpl.reference import DegeneratePointError, Reference

REF = Reference(dps=30)  # 30 digits judge float64 with 14 digits to spare
BATCH = 3


CASES = regime_cases(REGIMES)


@pytest.mark.reference
@pytest.mark.parametrize(("name", "regime"), CASES)
@settings(max_examples=ref_examples(0.12))
@given(data=st.data())
def test_poisson_tensor_within_error_model(name, regime, data):
    alg = catalogue(name)
    n = alg.dim
    theta = data.draw(cocycles(alg, exact=False), label="theta")
    ups = data.draw(
        upsilons(n, exact=False, zero=(None if regime != "near_degenerate" else False)),
        label="upsilon",
    )
    if regime == "near_degenerate" and not ups.any():
        assume(False)
    pts = [
        data.draw(points(alg, theta, ups, regime=regime), label=f"point {k}") for k in range(BATCH)
    ]
    x = np.array([p[0] for p in pts])
    pi = np.array([p[1] for p in pts])
    res = fast.poisson_batch(alg.f, theta, ups, x, pi)
    assert res.P.shape == (BATCH, 2 * n, 2 * n) and res.cond_phi.shape == (BATCH,)
    for k in range(BATCH):
        if res.degenerate[k]:
            assert np.all(np.isnan(res.P[k])) and np.isinf(res.error_bound[k])
            continue
        try:
            P_ref = REF.poisson_tensor(alg.f, theta, ups, x[k], pi[k])
        except DegeneratePointError:
            pytest.fail(f"reference finds point {k} degenerate but fast did not flag it")
        assert_within_bound(
            res.P[k : k + 1],
            P_ref[None],
            res.error_bound[k : k + 1],
            f"poisson_tensor[{name}, {regime}]",
            inputs=f"x={x[k]!r}, pi={pi[k]!r}",
        )


@pytest.mark.reference
@pytest.mark.parametrize("tau_scale", [0.0, 0.3])
@settings(max_examples=ref_examples(0.4))
@given(data=st.data())
def test_su2_closed_form_matches_generic_path(tau_scale, data):
    """su(2): the closed-form kernel and the generic matrix kernel agree within the sum of their bounds."""
    alg = su2()
    theta = data.draw(cocycles(alg, exact=False))
    ups = data.draw(upsilons(3, exact=False)) * tau_scale
    pts = [data.draw(points(alg, regime="generic")) for _ in range(4)]
    x = np.array([p[0] for p in pts]) * 2
    pi = np.array([p[1] for p in pts])
    closed = fast.poisson_batch(alg.f, theta, ups, x, pi)
    assert closed.path.startswith("su2")
    with np.errstate(all="ignore"):
        P_gen, _, _, bound_gen, _ = _generic_poisson(
            alg.f, theta if theta.any() else None, ups if ups.any() else None, x, pi
        )
    assert_within_bound(
        closed.P, P_gen, closed.error_bound + bound_gen, "su(2) closed form vs generic path"
    )


def test_degenerate_points_flagged_not_dropped():
    """A batch containing points on Pi_1 keeps its shape; those points are NaN and flagged."""
    alg = su2()
    tau = np.array([0.0, 0.0, 0.5])
    ups = np.einsum("l,lmn->mn", tau, alg.f)
    x = np.zeros((4, 3))
    pi = np.array(
        [[0.1, 0.2, 2.0], [0.3, 0.1, 0.5], [0.0, 0.0, 2.0], [1.0, 1.0, 1.0]]
    )  # pi.tau = 1 at 0 and 2
    res = fast.poisson_batch(alg.f, np.zeros((3, 3)), ups, x, pi)
    assert res.degenerate.tolist() == [True, False, True, False]
    assert np.all(np.isnan(res.P[[0, 2]])) and np.all(np.isfinite(res.P[[1, 3]]))
    with pytest.raises(
        ValueError, match=r"2 point\(s\) on the degenerate set Pi_1.*\(0,\), \(2,\)"
    ):
        fast.poisson_tensor(alg.f, np.zeros((3, 3)), ups, x, pi)


def test_components_layout_equals_points_layout():
    alg = catalogue("su(3)")
    rng = np.random.default_rng(7)
    x, pi = rng.uniform(-0.5, 0.5, (5, 8)), rng.normal(size=(5, 8))
    ups = np.zeros((8, 8))
    ups[0, 1], ups[1, 0] = 0.2, -0.2
    a = fast.poisson_batch(alg.f, np.zeros((8, 8)), ups, x, pi).P
    b = fast.poisson_batch(alg.f, np.zeros((8, 8)), ups, x.T, pi.T, layout="components").P
    assert np.array_equal(a, np.moveaxis(b, -1, 0))
    for layout in ("points", "components"):
        s = su2()
        r1 = fast.poisson_batch(s.f, np.zeros((3, 3)), ups[:3, :3], x[:, :3], pi[:, :3]).P
        r2 = fast.poisson_batch(
            s.f, np.zeros((3, 3)), ups[:3, :3], x[:, :3].T, pi[:, :3].T, layout="components"
        ).P
        assert np.array_equal(r1, np.moveaxis(r2, -1, 0)), layout


def test_work_skipped_when_upsilon_and_theta_vanish():
    alg = catalogue("so(4)")
    z = np.zeros((6, 6))
    res = fast.poisson_batch(alg.f, z, z, np.full((2, 6), 0.1), np.ones((2, 6)))
    assert "no Phi" in res.path and np.all(res.cond_phi == 1.0)
    assert np.all(res.P[:, :6, :6] == 0.0)


@pytest.mark.parametrize("name", ["su(2)", "sl(3,R)"])
@pytest.mark.parametrize("layout", ["points", "components"])
def test_out_buffer_gives_identical_results(name, layout):
    """Writing into a caller's buffer changes nothing but where the result lives; a wrong buffer is refused."""
    alg = catalogue(name)
    n = alg.dim
    rng = np.random.default_rng(11)
    x, pi = rng.uniform(-0.5, 0.5, (7, n)), rng.normal(size=(7, n))
    ups = np.zeros((n, n))
    ups[0, 1], ups[1, 0] = 0.3, -0.3
    if layout == "components":
        x, pi = x.T.copy(), pi.T.copy()
    fresh = fast.poisson_batch(alg.f, np.zeros((n, n)), ups, x, pi, layout=layout)
    buf = np.full(fresh.P.shape, np.nan)
    reused = fast.poisson_batch(alg.f, np.zeros((n, n)), ups, x, pi, layout=layout, out=buf)
    if name == "su(2)" or layout == "points":
        assert reused.P is buf or np.shares_memory(reused.P, buf)
    assert np.array_equal(reused.P, fresh.P)
    with pytest.raises(ValueError, match="out must be a C-contiguous float64 array of shape"):
        fast.poisson_batch(alg.f, np.zeros((n, n)), ups, x, pi, layout=layout, out=np.empty((3, 3)))
