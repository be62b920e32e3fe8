"""The lane-batched full-state kernel (issue 25; refimpl._full_state_batch, codegen.full_state_batch).

Definition checked: ``W`` trajectories run side by side in SIMD lanes, each with its own Jorba-Zou
control, step count and failure status; a batched flow returns for each trajectory what the flow of
that trajectory alone returns, to within the two flows' errors.

Independent routes: the single-trajectory kernel compiled for every structure
(:func:`refimpl._full_state_kernel.adaptive`, table-driven, no code generation, no lanes) for the
kernel-level checks, and the protocol flow of each trajectory alone (the single-trajectory path) for
the batched protocol flow.

Error models.
- Kernel against kernel (same method, same tolerance, same order): the two differ only in which
  multiply-adds are fused (one rounding each way) and in the summation shape of the derived and
  state rows (a balanced tree against a chain, both within ``(terms) eps`` of the exact sum). Each
  step's local difference is then at most ``c eps max(1, |y|)`` with ``c <= 10^2`` (the order times
  the terms per row, both below 10 here), carried over ``S`` steps with an amplification of at most
  10 over the short spans used: ``|a - b| <= 10^3 S eps max(1, |y|)``. The step counts are equal:
  each trajectory's steps are set by its own coefficients only.
- Batched flow against single flows: each is within ``K tol max(1, |ref|)`` of the exact flow (the
  two-run control's promise with the factor ``K = 100`` of tests/test_compiled_any_algebra.py, the
  estimate being an estimate), so they differ by at most ``2 K tol max(1, |.|)`` plus the rounding
  floor ``10^3 n eps``.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from tstarg.refimpl import _full_state as fs_mod
from tstarg.refimpl import _full_state_batch as fsb
from tstarg.refimpl import _full_state_kernel as fk
from tstarg.refimpl._catalogue import bianchi
from tstarg.refimpl._cohomology import cocycle_basis
from tstarg.refimpl.codegen.full_state_batch import batch_source, share_groups
from tstarg.refimpl.fast import implementation as FAST
from tstarg.refimpl.flows import cached_model
from tstarg.refimpl.flows._common import _AbelianPart

EPS = np.finfo(float).eps
K = 100.0
W = fsb.LANES
needs_numba = pytest.mark.skipif(not fs_mod._ct.HAVE_NUMBA, reason="numba not importable")


def _args():
    """Bianchi III with a cocycle Theta (a 3-dimensional structure: one cheap compilation)."""
    alg = bianchi("III")
    theta = np.asarray(
        sum(c * b for c, b in zip([0.5, -0.3, 0.2], cocycle_basis(alg, exact=False))), float
    )
    rng = np.random.default_rng(2)
    A = rng.standard_normal((3, 3))
    inertia = A @ A.T / 3 + np.eye(3)
    return alg.f, theta, np.zeros((3, 3)), inertia, None


def _ad(f, x):
    return scipy.linalg.expm(np.einsum("a,mab->mb", np.asarray(x, float), np.asarray(f, float)))


def _states(fs, model, N, seed=7, scale=1.0):
    """Packed starting rows (N, d) of the full state for N random points (momenta times ``scale``)."""
    rng = np.random.default_rng(seed)
    x0 = 0.3 * rng.standard_normal((3, N))
    pi0 = scale * rng.standard_normal((3, N))
    G0 = np.empty((N, fs.r, fs.r), dtype=fs.mats.dtype)
    fk.exp_batch(np.ascontiguousarray(x0.T), fs.mats, G0)
    s0 = None if fs.abelian is None else fs.abelian.P @ x0
    return fs_mod._pack(fs, pi0, None, G0, s0)


def _single(fs, y, T, tol, P):
    """The table-driven single-trajectory kernel (the independent route)."""
    out = np.empty_like(y)
    steps = np.zeros(y.shape[0], dtype=np.int64)
    fk.adaptive(y, T, tol, P, 10**7, *fs.tables(), out, steps)
    return out, steps


@pytest.fixture(scope="module")
def fs():
    model = cached_model(*_args())
    return model, fs_mod.full_state(model, _AbelianPart)


def _force(monkeypatch, f, form):
    """Make ``f`` (a small structure) take the lane kernel ``form``: ``written`` (its own, generated)
    or ``tables`` (refimpl._full_state_batch.adaptive_packed: MAX_GENERATED_TERMS = 0)."""
    if form == "tables":
        monkeypatch.setattr(fsb, "MAX_GENERATED_TERMS", 0)
    monkeypatch.delitem(f.__dict__, "_batch_kernel", raising=False)


def _assert_rounding_close(a, b, steps):
    bound = 1e3 * np.maximum(steps, 1)[:, None] * EPS * np.maximum(1.0, np.abs(b))
    assert np.all(np.isfinite(a)) and np.all(np.abs(a - b) <= bound), np.max(np.abs(a - b))


@needs_numba
@pytest.mark.parametrize("N", [1, W - 1, W, W + 1, 3 * W + 2])
def test_batch_kernel_equals_the_single_kernel(fs, N):
    """Odd batch sizes (fewer trajectories than lanes, one more, several blocks): every row as the
    single-trajectory kernel computes it, with the same step count; the input rows are not written."""
    model, f = fs
    y = _states(f, model, N)
    keep = y.copy()
    T, tol = 1.3, 1e-12
    P = fs_mod.default_order(tol)
    out, steps = fsb.run(f, y, T, tol, P, 10**7, generated=True)
    ref, rsteps = _single(f, y, T, tol, P)
    np.testing.assert_array_equal(y, keep)
    np.testing.assert_array_equal(steps, rsteps)
    assert np.all(steps > 0)
    _assert_rounding_close(out, ref, rsteps)


@needs_numba
def test_batch_kernel_backwards_in_time(fs):
    model, f = fs
    y = _states(f, model, W + 3, seed=9)
    T, tol = -0.9, 1e-10
    P = fs_mod.default_order(tol)
    out, steps = fsb.run(f, y, T, tol, P, 10**7, generated=True)
    ref, rsteps = _single(f, y, T, tol, P)
    np.testing.assert_array_equal(steps, rsteps)
    _assert_rounding_close(out, ref, rsteps)


@needs_numba
@pytest.mark.parametrize("form", ["written", "tables"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_failing_lane_is_reported_alone(fs, monkeypatch, bad, form):
    """A non-finite row fails in its own lane (negative status, NaN row); every other row is what it
    is without the bad one (its lane may change: rounding-level), and the flow's runner refuses the
    batch naming that row and only it. Every form of the kernel (:func:`_force`)."""
    model, f = fs
    _force(monkeypatch, f, form)
    y = _states(f, model, 2 * W + 1, seed=3)
    y[2, 0] = bad
    T, tol = 0.8, 1e-11
    P = fs_mod.default_order(tol)
    out, steps = fsb.run(f, y, T, tol, P, 10**7, generated=True)
    assert steps[2] < 0 and np.all(np.isnan(out[2]))
    good = np.array([i for i in range(y.shape[0]) if i != 2])
    ref, rsteps = _single(f, np.ascontiguousarray(y[good]), T, tol, P)
    np.testing.assert_array_equal(steps[good], rsteps)
    _assert_rounding_close(out[good], ref, rsteps)
    with pytest.raises(ValueError, match=r"trajectories \[2\] became non-finite"):
        fs_mod._run(f, y, T, tol, generated=True)
    f.__dict__.pop("_batch_kernel", None)  # the next test builds its own form


@needs_numba
def test_step_budget_is_reported_per_lane(fs):
    """``max_steps`` exceeded: status -3 on every row that needs more steps, none dropped."""
    model, f = fs
    y = _states(f, model, W + 1, seed=4)
    out, steps = fsb.run(f, y, 50.0, 1e-12, fs_mod.default_order(1e-12), 3, generated=True)
    assert np.all(steps == -3) and np.all(np.isnan(out))


@needs_numba
def test_short_batches_run_the_kernel_compiled_for_every_structure(fs, monkeypatch):
    """By default (``GENERATED_MIN_WORK = 0``) every batch runs the structure's generated lane kernel;
    with a threshold, below ``N |T| = GENERATED_MIN_WORK`` a batch runs :func:`adaptive_packed` (no
    compilation per structure), from it on the generated one: the choice is seen, and the short
    batch's rows are the table-driven single kernel's (same step counts, rounding model above)."""
    model, f = fs
    seen = []
    real = fsb.kernel

    def spy(fs_, generated=True):
        kb = real(fs_, generated)
        seen.append(kb[0] is fsb.adaptive_packed)
        return kb

    monkeypatch.setattr(fsb, "kernel", spy)
    y = _states(f, model, W + 1, seed=13)
    T, tol = 1.2, 1e-12
    fsb.run(f, y, T, tol, fs_mod.default_order(tol), 1)  # the default: the generated one
    assert seen == [False]
    seen.clear()
    monkeypatch.setattr(fsb, "GENERATED_MIN_WORK", 1024.0)
    assert y.shape[0] * T < fsb.GENERATED_MIN_WORK <= 1000 * y.shape[0] * T
    P = fs_mod.default_order(tol)
    out, steps = fsb.run(f, y, T, tol, P, 10**7)
    ref, rsteps = _single(f, y, T, tol, P)
    np.testing.assert_array_equal(steps, rsteps)
    _assert_rounding_close(out, ref, rsteps)
    fsb.run(f, y, 1000 * T, tol, P, 1)  # the step budget ends it at once: only the choice matters
    assert seen == [True, False]


@needs_numba
def test_batched_protocol_flow_equals_single_flows(monkeypatch):
    """The protocol ``flow`` of a batch large enough for the lane kernel (``N |t| >= 64``; the kernel
    is seen to run) against each trajectory's flow alone: within the two flows' errors; the caller's
    arrays are not written."""
    calls = []
    real = fsb.run

    def spy(*a, **kw):
        calls.append(a[1].shape[0])
        return real(*a, **kw)

    monkeypatch.setattr(fsb, "run", spy)
    f, theta, ups, inertia, pot = _args()
    rng = np.random.default_rng(5)
    N, T = 2 * W + 1, 8.0
    assert N * T >= fs_mod.GENERATED_MIN_WORK
    X0 = 0.3 * rng.standard_normal((N, 3))
    P0 = rng.standard_normal((N, 3))
    keep = X0.copy(), P0.copy()
    X, P = FAST.flow(f, theta, ups, inertia, pot, X0, P0, T)
    np.testing.assert_array_equal(X0, keep[0])
    np.testing.assert_array_equal(P0, keep[1])
    assert calls and max(calls) == N
    tol = FAST.flow_tolerance
    floor = 1e3 * 3 * EPS
    for i in [0, W - 1, N - 1]:
        x1, p1 = FAST.flow(f, theta, ups, inertia, pot, X0[i], P0[i], T)
        scale = max(1.0, float(np.max(np.abs(p1))))
        assert np.max(np.abs(P[i] - p1)) <= (2 * K * tol + floor) * scale
        # Ad(exp x) by scipy's expm (its own rounding, 100 eps exp(|ad x|_1) |Ad|, in the floor's place)
        Ad, Ad1 = _ad(f, X[i]), _ad(f, x1)
        cond = np.exp(np.linalg.norm(np.einsum("a,mab->mb", x1, f), 1))
        scale = max(1.0, float(np.max(np.abs(Ad1))))
        assert np.max(np.abs(Ad - Ad1)) <= (2 * K * tol + 100 * EPS * cond) * scale


def test_source_depends_on_structure_only():
    """Two inertias (different numbers, same nonzero pattern) give the same kernel source; bad lane
    counts are refused by name."""
    f, theta, ups, inertia, pot = _args()
    srcs = []
    for scale in (1.0, 2.5):
        model = cached_model(f, theta, ups, scale * inertia, pot)
        fsx = fs_mod.FullState(model, model.representation)
        srcs.append(batch_source(fsx.tables(), fsx.d))
    assert srcs[0] == srcs[1]
    with pytest.raises(ValueError, match="lanes W"):
        batch_source(fsx.tables(), fsx.d, W=0)


@pytest.mark.slow
@needs_numba
@pytest.mark.parametrize("name", ["se(3)", "so(4)", "su(3)", "h(3)", "sl(3,R)"])
def test_batch_kernel_on_other_algebras_slow(name):
    """Every catalogued structure kind (affine, compact, complex representation, nilpotent with the
    abelian part, split real): the lane kernel against the table-driven single kernel, W + 1 rows
    (one compilation per structure, several seconds each: slow)."""
    from tstarg.refimpl._catalogue import catalogue

    alg = catalogue(name)
    n = alg.f.shape[0]
    rng = np.random.default_rng(1)
    A = rng.standard_normal((n, n))
    z = np.zeros((n, n))
    model = cached_model(alg.f, z, z, A @ A.T / n + np.eye(n), None)
    f = fs_mod.full_state(model, _AbelianPart)
    N = W + 1
    x0 = 0.2 * rng.standard_normal((n, N))
    pi0 = rng.standard_normal((n, N))
    G0 = np.empty((N, f.r, f.r), dtype=f.mats.dtype)
    fk.exp_batch(np.ascontiguousarray(x0.T), f.mats, G0)
    s0 = None if f.abelian is None else f.abelian.P @ x0
    y = fs_mod._pack(f, pi0, None, G0, s0)
    T, tol = 1.0, 1e-12
    P = fs_mod.default_order(tol)
    out, steps = fsb.run(f, y, T, tol, P, 10**7, generated=True)
    ref, rsteps = _single(f, y, T, tol, P)
    np.testing.assert_array_equal(steps, rsteps)
    _assert_rounding_close(out, ref, rsteps)


def test_share_groups_partition_the_products():
    """Every product in exactly one group of at most ``size``; products of one factor pair with all
    four of another (a 2 x 4 block) land in one group of 8 with 6 factor rows loaded, not 16."""
    pu = np.array([0, 0, 0, 0, 1, 1, 1, 1, 2, 3, 4])
    pw = np.array([5, 6, 7, 8, 5, 6, 7, 8, 9, 9, 9])
    prods = [0, 4, 1, 5, 2, 6, 3, 7, 8, 9, 10]
    for size in (1, 3, 8, 12):
        groups = share_groups(prods, pu, pw, size)
        assert sorted(p for g in groups for p in g) == sorted(prods)
        assert all(1 <= len(g) <= size for g in groups)
    first = share_groups(prods, pu, pw, 8)[0]
    assert sorted(first) == list(range(8))
    assert len({pu[p] for p in first}) + len({pw[p] for p in first}) == 6


def test_lane_kernel_spec_covers_the_field():
    """The generated lane kernel's spec (:func:`batch_spec`) on su(3) (140 general products, complex
    representation): every general product in exactly one group of at most ``GROUP``, every product
    with a constant factor among the constant classes, every term of every derived and state row of
    the tables once, each with its number's index into ``c`` (:func:`batch_numbers`); the source
    names the IR version (numba's cache key is the source's text)."""
    from tstarg.refimpl._catalogue import catalogue
    from tstarg.refimpl.codegen import _full_state_ir as ir
    from tstarg.refimpl.codegen.full_state_batch import GROUP, batch_numbers, batch_spec

    su3 = catalogue("su(3)")
    z = np.zeros((8, 8))
    big = cached_model(su3.f, z, z, np.diag(np.linspace(1.0, 2.0, 8)), None)
    fbig = fs_mod.FullState(big, big.representation)
    tb = fbig.tables()
    c = batch_numbers(tb)
    ncoef, derived, groups, consts, state = batch_spec(tb)
    assert ncoef == len(c)
    general = np.flatnonzero(tb[7] == 0)
    assert len(general) == 140
    assert sorted(p for g in groups for p, _, _ in g) == general.tolist()
    assert all(1 <= len(g) <= GROUP for g in groups)
    assert all((tb[5][p], tb[6][p]) == (u, w) for g in groups for p, u, w in g)
    assert sorted(p for p, *_ in consts) == np.flatnonzero(np.isin(tb[7], (1, 2, 3))).tolist()
    assert [r for r, _ in derived] == tb[1].tolist()
    assert [c[ci] for _, terms in derived for ci, _ in terms] == tb[4].tolist()
    assert [r for r, _ in state] == tb[8].tolist()
    quad = [(c[ci], x) for _, terms in state for kd, ci, x in terms if kd == ir.SCALED]
    assert quad == list(zip(tb[11].tolist(), tb[10].tolist()))
    lin = [(c[ci], x) for _, terms in state for kd, ci, x in terms if kd != ir.SCALED]
    assert lin == list(zip(tb[14].tolist(), tb[13].tolist()))
    assert f"IR version {ir.IR_VERSION}" in batch_source(tb, fbig.d)


@needs_numba
@pytest.mark.parametrize("N", [1, W + 1, 2 * W + 3])
def test_packed_batch_kernel_equals_the_single_kernel(fs, monkeypatch, N):
    """The packed kernel compiled for every structure (forced on a small structure by
    :func:`_force`) against the table-driven single kernel: every row, the same step counts, under the rounding model of the written-out form (the same
    sums in the same order, FMAs possibly contracted differently); the blocks' pairs that are no
    product (the zero row into the sink row) change no row."""
    model, f = fs
    _force(monkeypatch, f, "tables")
    y = _states(f, model, N, seed=11)
    keep = y.copy()
    T, tol = 1.1, 1e-12
    P = fs_mod.default_order(tol)
    fn, args = fsb.kernel(f)
    assert fn is fsb.adaptive_packed
    gp, gu, gw = args[-3:]
    tb = f.tables()
    nv, npr = int(tb[0]), len(tb[5])
    general = nv + np.flatnonzero(tb[7] == 0)
    # every general product written by exactly one pair of a block, every other pair to the sink row
    assert sorted(gp[gp != nv + npr + 1].tolist()) == sorted(general.tolist())
    assert len(gp) == 4 * len(gu) == 2 * len(gw)  # blocks of 2 x 4 pairs
    real = gp != nv + npr + 1  # each real pair (i, j) of block g: the product u_i w_j
    assert np.all(tb[5][gp[real] - nv] == gu.reshape(-1, 2).repeat(4, axis=1).ravel()[real])
    assert np.all(tb[6][gp[real] - nv] == np.tile(gw.reshape(-1, 4), (1, 2)).ravel()[real])
    out, steps = fsb.run(f, y, T, tol, P, 10**7, generated=True)
    f.__dict__.pop("_batch_kernel")  # the next test gets the written-out form again
    ref, rsteps = _single(f, y, T, tol, P)
    np.testing.assert_array_equal(y, keep)
    np.testing.assert_array_equal(steps, rsteps)
    _assert_rounding_close(out, ref, rsteps)


@needs_numba
@pytest.mark.parametrize("name", ["h(3) + gravity", "R^3"])
def test_packed_kernel_on_constant_factors(name):
    """:func:`adaptive_packed` (its order body the IR of
    :func:`refimpl.codegen._full_state_ir.packed_order`) on the branches the Bianchi III fixture does
    not reach: products with a constant first, second or both factors and linear terms in a constant
    row (h(3) with gravity, the abelian R^3; seen in the tables), against the table-driven single
    kernel (same step counts, the rounding model above)."""
    from tstarg.refimpl._catalogue import catalogue

    alg = catalogue(name.split(" ")[0])
    n = alg.f.shape[0]
    rng = np.random.default_rng(17)
    A = rng.standard_normal((n, n))
    z = np.zeros((n, n))
    grav = "gravity" in name
    pot = {"kind": "gravity", "L": np.arange(1.0, n + 1), "gamma": np.ones(n)} if grav else None
    f = fs_mod.full_state(cached_model(alg.f, z, z, A @ A.T / n + np.eye(n), pot), _AbelianPart)
    tb = f.tables()
    want = {1, 2} if grav else {3}
    assert want <= set(tb[7].tolist()) and (not grav or np.any(tb[15]))
    N = W + 3
    x0 = 0.2 * rng.standard_normal((n, N))
    G0 = np.empty((N, f.r, f.r), dtype=f.mats.dtype)
    fk.exp_batch(np.ascontiguousarray(x0.T), f.mats, G0)
    s0 = None if f.abelian is None else f.abelian.P @ x0
    ga0 = rng.standard_normal((n, N)) if grav else None
    y = fs_mod._pack(f, rng.standard_normal((n, N)), ga0, G0, s0)
    T, tol = 1.0, 1e-12
    P = fs_mod.default_order(tol)
    out, steps = fsb.run(f, y, T, tol, P, 10**7, generated=False)
    ref, rsteps = _single(f, y, T, tol, P)
    np.testing.assert_array_equal(steps, rsteps)
    _assert_rounding_close(out, ref, rsteps)


@needs_numba
def test_time_probe_runs_on_a_sample_of_the_batch(monkeypatch):
    """fast_flow's time probe (issue 30 budget) runs on at most PROBE_ROWS trajectories, not on the
    whole batch; the budget still refuses, with its estimate, a batch it cannot afford."""
    from tstarg.refimpl import _validate
    from tstarg.refimpl.flows import _fast

    sizes = []
    real = fsb.run

    def spy(*a, **kw):
        sizes.append(a[1].shape[0])
        return real(*a, **kw)

    monkeypatch.setattr(fsb, "run", spy)
    f, theta, ups, inertia, pot = _args()
    rng = np.random.default_rng(6)
    N, T = 3 * _fast.PROBE_ROWS, 2.0
    assert N * T >= 256  # the probed regime of fast_flow
    X0 = 0.3 * rng.standard_normal((N, 3))
    P0 = rng.standard_normal((N, 3))
    FAST.flow(f, theta, ups, inertia, pot, X0, P0, T)
    assert N in sizes  # the run itself
    assert min(sizes) <= _fast.PROBE_ROWS and sizes.count(N) <= 2  # probes: the sample only
    monkeypatch.setattr(_validate, "TIME_BUDGET_S", 1e-9)
    with pytest.raises(_validate.BudgetError, match="would take about"):
        FAST.flow(f, theta, ups, inertia, pot, X0, P0, T)


def test_batch_rows_near_the_float64_floor_are_retried_by_the_control():
    """The control adds the logarithm's residual to every row's estimate (its ``floor`` hook), so a
    batch row over ``tol`` only once that residual is added is retried by the control as a single
    trajectory is: the batch answers wherever each row alone answers. The bench's Bianchi VI0 with a
    cocycle, rows drawn as in its batch column: rows 2 and 13 (estimates 1.07e-10 and 1.17e-10 when the
    control did not see the residual, tol 1e-10) pass alone. Expected: the single flows, within the
    module's batched-against-single model ``2 K tol max(1, |.|) + 10^3 n eps`` (and no row refused)."""
    from tstarg.reports import _bench_protocol as bp

    p = bp.protocol_problem("bianchi_cocycle")
    X, P = bp.batch_initial(p, 64)
    rows = [0, 1, 2, 13, 26, 36]
    xs, ps = FAST.flow(*p.args(X[rows], P[rows]))
    tol, K, n = FAST.flow_tolerance, 100.0, p.n
    for i, k in enumerate(rows):
        x1, p1 = FAST.flow(*p.args(X[k], P[k]))
        for got, want in ((xs[i], x1), (ps[i], p1)):
            bound = (
                2 * K * tol * max(1.0, float(np.max(np.abs(want)))) + 1e3 * n * np.finfo(float).eps
            )
            assert np.all(np.isfinite(got)) and np.max(np.abs(got - want)) <= bound, (k, got, want)


@needs_numba
def test_pair_kernel_equals_two_single_runs(fs, monkeypatch):
    """The first pair on two lanes (:func:`refimpl._full_state_batch.pair_first`): each lane is the
    generated single kernel's run at its tolerance and order, bitwise (the same operations; the
    series computed to the larger order for both) -- with A or B finishing first, each lane's step
    budget and a non-finite start failing both lanes by status; the input row is not written."""
    model, f = fs
    y = _states(f, model, 1, seed=21)
    keep = y.copy()
    T = 1.7
    mod = f.module()

    def single(eps, P, budget=10**7, row=y):
        out, st = np.empty_like(row), np.zeros(1, dtype=np.int64)
        mod.adaptive(row, T, eps, P, budget, f.coef, out, st)
        return out, st

    runs = [(1e-6, fs_mod.default_order(1e-6)), (2e-15, fs_mod.default_order(2e-15))]
    for (ea, pa), (eb, pb) in (runs, runs[::-1]):  # either lane the longer one
        A, B, sa, sb = fsb.pair_first(f, y, T, ea, eb, pa, pb)
        (A1, sa1), (B1, sb1) = single(ea, pa), single(eb, pb)
        assert sa[0] != sb[0] and min(sa[0], sb[0]) > 0
        np.testing.assert_array_equal(A, A1)
        np.testing.assert_array_equal(B, B1)
        np.testing.assert_array_equal(sa, sa1)
        np.testing.assert_array_equal(sb, sb1)
    np.testing.assert_array_equal(y, keep)
    # the step budget between the two runs' step counts: the longer lane fails alone (-3)
    (ea, pa), (eb, pb) = runs
    sa1, sb1 = single(ea, pa)[1][0], single(eb, pb)[1][0]
    lo, hi = sorted((sa1, sb1))
    monkeypatch.setattr(
        fsb, "MAX_STEPS", int(lo)
    )  # pair_first's budget: _full_state_batch.MAX_STEPS
    A, B, sa, sb = fsb.pair_first(f, y, T, ea, eb, pa, pb)
    monkeypatch.undo()
    short_a = sa1 <= sb1
    assert (sa[0] > 0) == short_a and (sb[0] > 0) != short_a
    assert min(sa[0], sb[0]) == -3 and np.all(np.isnan(A if not short_a else B))
    assert hi > lo
    bad = y.copy()
    bad[0, 0] = np.nan
    A, B, sa, sb = fsb.pair_first(f, bad, T, ea, eb, pa, pb)
    assert sa[0] == sb[0] == -1 and np.all(np.isnan(A)) and np.all(np.isnan(B))
    with pytest.raises(ValueError, match=r"y0 must have shape \(1, "):
        fsb.pair_first(f, np.concatenate([y, y]), T, ea, eb, pa, pb)


@needs_numba
def test_pair_lanes_bitwise_on_long_runs(fs):
    """Lane by lane the pair kernel is the single kernel bitwise also over hundreds of steps, where a
    one-ulp difference of any order's coefficient would grow to many ulps: the order bodies fix every
    multiply-add's fusion in the IR (:class:`refimpl.codegen._taylor_ir._FOps`), the same on one
    lane and on two. (Left to the back end's contraction, the two bodies fused different products of
    a sum: on these starts the lanes ended up to 1e-12 from the single runs.)"""
    model, f = fs
    mod = f.module()
    T = 40.0
    (ea, pa), (eb, pb) = (
        (fs_mod.A_LOOSE, fs_mod._FIRST_ORDERS[0]),
        (
            fs_mod.EPS_B_FIRST,
            fs_mod._FIRST_ORDERS[1],
        ),
    )
    y3 = _states(f, model, 3, seed=5, scale=10.0)
    for i in range(3):
        y = y3[i : i + 1].copy()
        A, B, sa, sb = fsb.pair_first(f, y, T, ea, eb, pa, pb)
        for eps, P, got, st in ((ea, pa, A, sa), (eb, pb, B, sb)):
            out, s1 = np.empty_like(y), np.zeros(1, dtype=np.int64)
            mod.adaptive(y, T, eps, P, 10**7, f.coef, out, s1)
            assert s1[0] > 100 and st[0] == s1[0], (i, st, s1)
            assert np.all(np.isfinite(out))
            np.testing.assert_array_equal(got, out)


@pytest.mark.parametrize("W", [2, 4, 8])
@pytest.mark.parametrize("per_loop", [1, 3, 8])
def test_pack_plan_covers_each_product_once_with_its_factors(W, per_loop):
    """:func:`refimpl.codegen._full_state_ir.pack_plan` on random product lists (any rows, repeated
    factors, lengths not multiples of ``W``, none): every product on exactly one lane, that lane's two
    operands its own factor rows (through a packed stream or a broadcast row), padding lanes marked
    ``None``, streams never one row on every lane, the groups in loops of at most ``per_loop`` whose
    sizes differ by at most one and which keep the products' order (the order the state rows read
    them in does not matter, but the plan must be deterministic)."""
    from tstarg.refimpl.codegen._full_state_ir import pack_plan

    rng = np.random.default_rng(11)
    for n in (0, 1, W - 1, W, 3 * W + 1, 37):
        chunks, p = [], 0
        while p < n:
            m = int(rng.integers(1, 6))
            chunks.append(
                tuple(
                    (q, int(rng.integers(0, 5)), int(rng.integers(5, 9)))
                    for q in range(p, min(p + m, n))
                )
            )
            p += m
        prods = [t for ch in chunks for t in ch]
        loops, streams = pack_plan(tuple(chunks), W, per_loop)
        assert all(len(set(rows)) > 1 and len(rows) == W for rows in streams)
        groups = [g for lp in loops for g in lp]
        assert all(1 <= len(lp) <= per_loop for lp in loops)
        if loops:
            assert max(map(len, loops)) - min(map(len, loops)) <= 1
        assert len(groups) == -(-n // W)

        def rows(op):
            kind, x = op
            return streams[x] if kind == "s" else (x,) * W

        seen = []
        for ps, su, sw in groups:
            assert len(ps) == W
            for lane, q in enumerate(ps):
                if q is None:
                    continue
                seen.append(q)
                _, u, w = prods[q]
                assert (rows(su)[lane], rows(sw)[lane]) == (u, w)
        assert seen == [q for q, _, _ in prods]
        assert pack_plan(tuple(chunks), W, per_loop) == (loops, streams)
