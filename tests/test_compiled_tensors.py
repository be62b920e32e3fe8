"""The compiled (numba) Poisson tensors of refimpl._compiled_tensors against the numpy kernels and the
mpmath reference: the same tensor within the error model on every catalogue algebra, bounds that hold
against the reference, the same flags (degenerate, outside the chart), the same refusals of bad input,
every batch shape of the protocol, caller arrays untouched, and one compilation for every model."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from tests._helpers import assert_within_bound
from tstarg.refimpl import CATALOGUE_NAMES, catalogue, su2
from tstarg.refimpl import _compiled_tensors as ct
from tstarg.refimpl import _fast_kernels as fk
from tstarg.refimpl._errors import ChartError
from tstarg.refimpl.fast import implementation as fast
from tstarg.refimpl.reference import DegeneratePointError, Reference

pytestmark = pytest.mark.skipif(not ct.HAVE_NUMBA, reason="numba cannot be imported here")

EPS = np.finfo(float).eps


def _model(alg, kind: int, rng):
    """Theta (a coboundary -xi.f, a cocycle on every algebra) and Upsilon, each present or not."""
    n = alg.dim
    theta = (
        -np.einsum("k,kab->ab", rng.normal(size=n) * 0.3, alg.f) if kind & 1 else np.zeros((n, n))
    )
    u = rng.normal(size=(n, n)) * 0.15
    ups = u - u.T if kind & 2 else np.zeros((n, n))
    return theta, ups


def _points(alg, N, rng, spread=1.0):
    """Points of every size: ``x`` scaled so that ||ad_x||_F runs from 0 to about 1.3 * 2 pi * spread
    (the Bernoulli series, scaling and squaring beyond r = 0.7, and a few points past the chart edge)."""
    n = alg.dim
    x = rng.normal(size=(N, n))
    A = np.einsum("Na,iaj->Nij", x, alg.f)
    fro = np.sqrt(np.sum(A * A, axis=(1, 2)))
    target = np.linspace(0.0, 1.3 * 2 * np.pi * spread, N)
    x *= np.where(fro > 0, target / np.where(fro > 0, fro, 1.0), 1.0)[:, None]
    if not alg.f.any():
        x = rng.normal(size=(N, n)) * 3.0  # abelian: ad_x = 0, any x
    return x, rng.normal(size=(N, n))


def _both(alg, theta, ups, x, pi, **kw):
    with np.errstate(all="ignore"):
        c = fast.poisson_batch(alg.f, theta, ups, x, pi, compiled=True, **kw)
        p = fast.poisson_batch(alg.f, theta, ups, x, pi, compiled=False, **kw)
    return c, p


@pytest.mark.parametrize("name", CATALOGUE_NAMES)
def test_compiled_equals_numpy_within_error_model(name):
    """Every catalogue algebra, four models (Theta, Upsilon present or not), 40 points per model:
    |P_compiled - P_numpy| <= bound_compiled + bound_numpy (each bounds its distance to the exact
    tensor); the bounds are the same formula (equal to 1e-9 relative: only rounding of max|P| and the
    norms differs); the flags are identical."""
    alg = catalogue(name)
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    for kind in range(4):
        theta, ups = _model(alg, kind, rng)
        x, pi = _points(alg, 40, rng)
        c, p = _both(alg, theta, ups, x, pi)
        assert "compiled (numba)" in c.path and "numpy" in p.path
        assert np.array_equal(c.outside_chart, p.outside_chart), (name, kind)
        assert np.array_equal(c.degenerate, p.degenerate), (name, kind)
        bad = c.outside_chart | c.degenerate
        assert np.all(np.isnan(c.P[bad])) and np.all(np.isinf(c.error_bound[bad]))
        ok = ~bad
        assert ok.sum() >= 20, "the sample must exercise finite points"
        assert_within_bound(
            c.P[ok], p.P[ok], c.error_bound[ok] + p.error_bound[ok], f"{name} model {kind}"
        )
        np.testing.assert_allclose(c.error_bound[ok], p.error_bound[ok], rtol=1e-9)
        np.testing.assert_allclose(c.cond_phi[ok], p.cond_phi[ok], rtol=1e-9)
        np.testing.assert_allclose(c.cond_data[ok], p.cond_data[ok], rtol=1e-9)


REF = Reference(dps=30)


@pytest.mark.reference
@pytest.mark.parametrize(
    "name", ["su(2)", "sl(2,R)", "Bianchi VI_h(h=-1/4)", "aff(1)", "h(5)", "su(3)"]
)
def test_compiled_bound_contains_reference_error(name):
    """The compiled tensor is within its own bound of the 30-digit mpmath reference, on points from
    the series regime, the scaling-and-squaring regime (r > 0.7) and near the chart edge."""
    alg = catalogue(name)
    n = alg.dim
    rng = np.random.default_rng(5)
    theta, ups = _model(alg, 3, rng)
    x, pi = _points(alg, 4, rng, spread=0.74)  # ||ad_x||_F up to 0.96 * 2 pi
    res = fast.poisson_batch(alg.f, theta, ups, x, pi, compiled=True)
    assert not res.outside_chart.any() and not res.degenerate.any()
    P_ref = np.array([REF.poisson_tensor(alg.f, theta, ups, x[k], pi[k]) for k in range(len(x))])
    assert P_ref.shape == (len(x), 2 * n, 2 * n)
    assert_within_bound(res.P, P_ref, res.error_bound, f"compiled {name} vs reference")
    num = fast.poisson_batch(alg.f, theta, ups, x, pi, compiled=False)  # the fallback, same judge
    assert_within_bound(num.P, P_ref, num.error_bound, f"numpy {name} vs reference")


@pytest.mark.reference
def test_compiled_bound_holds_in_an_ill_conditioned_basis():
    """su(3) in a basis with condition number ~1e4: the summand-magnitude terms of the bound
    (forming S and ad_x under cancellation) are needed; the compiled bound still holds."""
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.normal(size=(8, 8)))
    C = q @ np.diag(np.logspace(0, -4, 8)) @ q.T
    alg = catalogue("su(3)").change_basis(C)
    theta, ups = _model(alg, 2, rng)
    x, pi = _points(alg, 3, rng, spread=0.5)
    res = fast.poisson_batch(alg.f, theta, ups, x, pi, compiled=True)
    assert not res.degenerate.any()
    P_ref = np.array([REF.poisson_tensor(alg.f, theta, ups, x[k], pi[k]) for k in range(len(x))])
    assert_within_bound(res.P, P_ref, res.error_bound, "compiled su(3), ill-conditioned basis")


@pytest.mark.parametrize("name", ["su(2)", "so(3)[other basis]", "sl(3,R)"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("which", ["x", "pi"])
def test_non_finite_input_refused_as_by_numpy(name, bad, which):
    """NaN or infinity in x or pi: the same ValueError, naming the input and the point, on both paths."""
    alg = catalogue(name)
    n = alg.dim
    x, pi = np.full((2, 3, n), 0.1), np.ones((2, 3, n))
    (x if which == "x" else pi)[1, 2, n - 1] = bad
    msgs = []
    for compiled in (True, False):
        with pytest.raises(
            ValueError, match=rf"{which} contains NaN or infinity at point\(s\) \(1, 2\)"
        ) as e:
            fast.poisson_batch(alg.f, np.zeros((n, n)), np.zeros((n, n)), x, pi, compiled=compiled)
        msgs.append(str(e.value))
    assert msgs[0] == msgs[1]


@pytest.mark.parametrize("name", ["su(2)", "se(3)"])
@pytest.mark.parametrize("batch", [(), (1,), (5,), (1, 1), (2, 3), (2, 1, 3), (1, 1, 1)])
def test_batch_shapes_of_the_protocol(name, batch):
    """Rank 0 to 3 and size-1 axes: P has the batch axes then (2n, 2n) (components layout: (2n, 2n)
    first), the protocol method returns the same, and every point equals its single-point result."""
    alg = catalogue(name)
    n = alg.dim
    rng = np.random.default_rng(len(batch))
    theta, ups = _model(alg, 3, rng)
    x = rng.uniform(-0.4, 0.4, batch + (n,))
    pi = rng.normal(size=batch + (n,))
    P = fast.poisson_tensor(alg.f, theta, ups, x, pi)
    assert P.shape == batch + (2 * n, 2 * n)
    res = fast.poisson_batch(alg.f, theta, ups, x, pi)
    assert "compiled" in res.path and np.array_equal(res.P, P)
    assert res.error_bound.shape == batch and res.degenerate.shape == batch
    xs, ps = x.reshape(-1, n), pi.reshape(-1, n)
    Pf = P.reshape(-1, 2 * n, 2 * n)
    for k in range(xs.shape[0]):  # a point's tensor does not depend on its batch
        assert np.array_equal(Pf[k], fast.poisson_tensor(alg.f, theta, ups, xs[k], ps[k]))
    comp = fast.poisson_batch(
        alg.f, theta, ups, np.moveaxis(x, -1, 0), np.moveaxis(pi, -1, 0), layout="components"
    )
    assert comp.P.shape == (2 * n, 2 * n) + batch
    assert np.array_equal(np.moveaxis(comp.P.reshape(2 * n, 2 * n, -1), -1, 0), Pf)


@pytest.mark.parametrize("name", ["su(2)", "su(3)"])
@pytest.mark.parametrize("layout", ["points", "components"])
def test_caller_arrays_untouched(name, layout):
    """Inputs (points inside and outside the chart, non-contiguous views) and the model are not written."""
    alg = catalogue(name)
    rng = np.random.default_rng(2)
    theta, ups = _model(alg, 3, rng)
    x, pi = _points(alg, 12, rng, spread=1.6)
    if layout == "components":
        x, pi = x.T, pi.T  # non-contiguous views of the caller's arrays
    keep = [a.copy() for a in (alg.f, theta, ups, x, pi)]
    res = fast.poisson_batch(alg.f, theta, ups, x, pi, layout=layout)
    assert res.outside_chart.any(), "the sample must reach past the chart edge"
    for a, b in zip((alg.f, theta, ups, x, pi), keep, strict=True):
        assert np.array_equal(a, b)


def test_degenerate_and_outside_points_flagged_and_refused():
    """su(2) closed form (pi.tau = 1) and the generic path (det Psi = 0 at a root of a cubic in s):
    flagged, NaN, inf bound, the same flags as numpy; the protocol raises naming the points."""
    alg = su2()
    tau = np.array([0.0, 0.0, 0.5])
    ups = np.einsum("l,lmn->mn", tau, alg.f)
    x = np.zeros((4, 3))
    x[3] = [7.0, 0.0, 0.0]  # |x| > 2 pi
    pi = np.array([[0.1, 0.2, 2.0], [0.3, 0.1, 0.5], [0.0, 0.0, 2.0], [1.0, 1.0, 1.0]])
    c, p = _both(alg, np.zeros((3, 3)), ups, x, pi)
    assert c.degenerate.tolist() == p.degenerate.tolist() == [True, False, True, False]
    assert c.outside_chart.tolist() == p.outside_chart.tolist() == [False, False, False, True]
    assert np.all(np.isnan(c.P[[0, 2, 3]])) and np.all(np.isfinite(c.P[1]))
    with pytest.raises(DegeneratePointError, match=r"2 point\(s\).*\(0,\), \(2,\)"):
        fast.poisson_tensor(alg.f, np.zeros((3, 3)), ups, x[:3], pi[:3])
    with pytest.raises(ChartError, match=r"1 point\(s\) x outside the chart.*\(3,\)"):
        fast.poisson_tensor(alg.f, np.zeros((3, 3)), ups, x, pi)
    # generic path: aff(1) has S = pi_1 J, so Upsilon = u J gives Psi = (1 - u pi_1) 1, singular
    # exactly at pi_1 = 1/u and to float64 accuracy at pi_1 = (1 - 2^-50)/u (cond_data ~ 2^50)
    g = catalogue("aff(1)")
    U = np.array([[0.0, 0.5], [-0.5, 0.0]])
    pi_g = np.array([[0.7, 2.0], [0.7, 2.0 - 2.0**-49], [0.7, 0.3]])
    x_g = np.full_like(pi_g, 0.2)
    c, p = _both(g, np.zeros((2, 2)), U, x_g, pi_g)
    assert c.degenerate.tolist() == p.degenerate.tolist() == [True, True, False]
    assert np.all(np.isnan(c.P[:2])) and np.all(np.isinf(c.error_bound[:2]))
    assert np.all(np.isfinite(c.P[2]))
    with pytest.raises(DegeneratePointError, match=r"2 point\(s\).*\(0,\), \(1,\)"):
        fast.poisson_tensor(g.f, np.zeros((2, 2)), U, x_g, pi_g)


def test_degenerate_at_origin_without_the_kernel():
    """_fast_kernels._degenerate_at_origin (the flows' start check, no kernel compiled) gives the flags of the
    compiled generic kernel and of numpy at x = 0 on aff(1)'s exactly singular and 2^-49-close Psi
    (see above), numpy's on every catalogue algebra but su(2) (its own closed form) under the four
    models of _model at |pi| from 1e-3 to 1e6 (the compiled flags equal numpy's: the tests above);
    and the fast flow refuses those aff(1) starts naming them."""
    g = catalogue("aff(1)")
    U = np.array([[0.0, 0.5], [-0.5, 0.0]])
    pi_g = np.array([[0.7, 2.0], [0.7, 2.0 - 2.0**-49], [0.7, 0.3]])
    z2 = np.zeros((2, 2))
    flags = fk._degenerate_at_origin(g.f, None, U, pi_g)
    c, p = _both(g, z2, U, np.zeros_like(pi_g), pi_g)
    assert flags.tolist() == c.degenerate.tolist() == p.degenerate.tolist() == [True, True, False]
    for k in range(3):  # one point at a time: its own route (2-d operations)
        one = fk._degenerate_at_origin(g.f, None, U, pi_g[k : k + 1])
        assert one.tolist() == [flags[k]]
    assert not fk._degenerate_at_origin(g.f, None, None, pi_g).any()
    for name in CATALOGUE_NAMES:
        alg = catalogue(name)
        if name == "su(2)" or alg.dim < 2:
            continue
        rng = np.random.default_rng(zlib.crc32(name.encode()))
        for kind in range(4):
            theta, ups = _model(alg, kind, rng)
            pi = rng.normal(size=(20, alg.dim)) * np.logspace(-3, 6, 20)[:, None]
            with np.errstate(all="ignore"):  # numpy's path: no kernel compiled per dimension here
                ref = fast.poisson_batch(alg.f, theta, ups, np.zeros_like(pi), pi, compiled=False)
            flags = fk._degenerate_at_origin(alg.f, theta, ups, pi)
            assert flags.tolist() == ref.degenerate.tolist(), (name, kind)
            ones = [fk._degenerate_at_origin(alg.f, theta, ups, q[None])[0] for q in pi]
            assert ones == flags.tolist(), (name, kind)
    I2 = np.diag([1.0, 2.0])
    with pytest.raises(ValueError, match=r"initial point\(s\) \[0, 1\] lie on the degenerate set"):
        fast.flow(g.f, z2, U, I2, None, np.zeros((3, 2)), pi_g, 1.0)


def test_numpy_path_when_numba_is_missing(monkeypatch):
    """Without numba the numpy kernels run, the path says so, and compiled=True is refused by name."""
    alg = catalogue("su(3)")
    rng = np.random.default_rng(1)
    theta, ups = _model(alg, 3, rng)
    x, pi = _points(alg, 6, rng, spread=0.5)
    want = fast.poisson_batch(alg.f, theta, ups, x, pi, compiled=False)
    monkeypatch.setattr(ct, "HAVE_NUMBA", False)
    got = fast.poisson_batch(alg.f, theta, ups, x, pi)
    assert got.path == want.path and got.path.endswith("numpy") and "compiled" not in got.path
    assert np.array_equal(got.P, want.P)
    with pytest.raises(ValueError, match="compiled=True needs numba"):
        fast.poisson_batch(alg.f, theta, ups, x, pi, compiled=True)


def test_one_compilation_for_every_model():
    """The numbers are arguments: new models, algebras of a dimension already seen and layouts
    compile nothing new. Modules: the su(2) one, the generic one (n read at run time) and one per
    dimension from ct.SPECIALISE_FROM on."""
    rng = np.random.default_rng(9)
    names = ["su(2)", "su(3)", *CATALOGUE_NAMES[:8]]
    for name in names:
        alg = catalogue(name)
        theta, ups = _model(alg, 3, rng)
        x, pi = _points(alg, 3, rng, spread=0.5)
        fast.poisson_batch(alg.f, theta, ups, x, pi)
    before = ct.compile_count()
    # module keys in this process (other tests may have added dimensions): su(2), or generic with
    # the dimension (None: n at run time), never anything of a model's numbers
    for key in ct._BY_CONSTS:
        assert key[0] == "su2" or (
            key[0] == "generic" and (key[1] is None or key[1] >= ct.SPECIALISE_FROM)
        )
    for name in CATALOGUE_NAMES[:8]:
        alg = catalogue(name)
        for kind in range(4):
            theta, ups = _model(alg, kind, rng)
            x, pi = _points(alg, 3, rng, spread=0.5)
            fast.poisson_batch(alg.f, theta, ups, x, pi)
            fast.poisson_batch(alg.f, theta, ups, x.T, pi.T, layout="components")
    assert ct.compile_count() == before


@pytest.mark.parametrize("name", ["su(2)", "su(3)"])
@pytest.mark.parametrize("layout", ["points", "components"])
def test_read_only_and_broadcast_inputs(name, layout):
    """Read-only arrays and zero-stride broadcasts are accepted and give what their writable copies give."""
    alg = catalogue(name)
    n = alg.dim
    rng = np.random.default_rng(4)
    theta, ups = _model(alg, 3, rng)
    x, pi = _points(alg, 5, rng, spread=0.5)
    if layout == "components":
        x, pi = x.T.copy(), pi.T.copy()
    want = fast.poisson_batch(alg.f, theta, ups, x, pi, layout=layout)
    ro_x, ro_pi = x.copy(), pi.copy()
    ro_x.setflags(write=False)
    ro_pi.setflags(write=False)
    got = fast.poisson_batch(alg.f, theta, ups, ro_x, ro_pi, layout=layout)
    assert np.array_equal(got.P, want.P) and np.array_equal(got.error_bound, want.error_bound)
    shape = (n, 4) if layout == "components" else (4, n)
    one_x = x[:, 1] if layout == "components" else x[1]
    one_pi = pi[:, 1] if layout == "components" else pi[1]
    bx = np.broadcast_to(one_x[:, None] if layout == "components" else one_x, shape)
    bp = np.broadcast_to(one_pi[:, None] if layout == "components" else one_pi, shape)
    b = fast.poisson_batch(alg.f, theta, ups, bx, bp, layout=layout)
    P1 = want.P[..., 1] if layout == "components" else want.P[1]
    for k in range(4):
        assert np.array_equal(b.P[..., k] if layout == "components" else b.P[k], P1)


@pytest.mark.parametrize("name", ["su(2)", "sl(3,R)"])
def test_input_past_the_magnitude_boundary_is_refused_by_both_paths(name):
    """Finite momenta near the float64 limit (1e308: their sum overflows, so a quick one-sum
    finiteness test cannot see them) lie past the boundary |v| <= 1e300 that every implementation
    states (refimpl._validate.MAX_MAGNITUDE): the compiled and the numpy path refuse them alike, by
    name, and a point just inside the boundary is answered by both with the same flags."""
    alg = catalogue(name)
    n = alg.dim
    z = np.zeros((n, n))
    x, pi = np.full((3, n), 0.1), np.full((3, n), 1e308)
    with np.errstate(over="ignore"):
        assert not np.isfinite(np.sum(pi))
    for compiled in (True, False):
        with pytest.raises(ValueError, match=r"pi .*1e\+308.*boundary"):
            fast.poisson_batch(alg.f, z, z, x, pi, compiled=compiled)
    c, p = _both(alg, z, z, x, np.full((3, n), 1e300))
    assert np.array_equal(c.degenerate, p.degenerate)
    assert np.array_equal(c.outside_chart, p.outside_chart)
    assert np.array_equal(np.isfinite(c.P), np.isfinite(p.P))


@pytest.mark.reference
def test_inverse_is_backward_stable_at_large_momenta():
    """Found by tests/test_fast_vs_reference.py (se(3), large_momenta): at |pi| ~ 1e6 with cond(Psi) ~
    1e6, a Gauss-Jordan inverse lost four more digits in S Psi^-1 than LAPACK's and broke the bound
    (error 5.6e-6 against a bound of 5.1e-7). The LU inverse keeps the error within the bound."""
    alg = catalogue("se(3)")
    th = np.array(
        [
            [0.0, -0.5, -1.125, 0.0, -0.75, 0.25],
            [0.5, 0.0, 0.5, 0.75, 0.0, -0.25],
            [1.125, -0.5, 0.0, -0.25, 0.25, 0.0],
            [0.0, -0.75, 0.25, 0.0, 0.0, 0.0],
            [0.75, 0.0, -0.25, 0.0, 0.0, 0.0],
            [-0.25, 0.25, 0.0, 0.0, 0.0, 0.0],
        ]
    )
    ups = np.array(
        [
            [0.0, 0.5625, -0.0625, 0.125, -0.125, -0.375],
            [-0.5625, 0.0, -0.5625, 0.0625, 0.4375, 0.1875],
            [0.0625, 0.5625, 0.0, 0.3125, -0.0625, -0.375],
            [-0.125, -0.0625, -0.3125, 0.0, 0.0625, -0.3125],
            [0.125, -0.4375, 0.0625, -0.0625, 0.0, 0.0],
            [0.375, -0.1875, 0.375, 0.3125, 0.0, 0.0],
        ]
    )
    x = np.zeros((1, 6))
    pi = np.array([[0.0, 0.0, 0.0, 830644.25518733, -804967.24108081, 0.0]])
    res = fast.poisson_batch(alg.f, th, ups, x, pi, compiled=True)
    assert not res.degenerate[0] and res.cond_phi[0] > 1e5  # the ill-conditioned regime
    P_ref = REF.poisson_tensor(alg.f, th, ups, x[0], pi[0])
    assert_within_bound(res.P, P_ref[None], res.error_bound, "compiled se(3), |pi| ~ 1e6")
