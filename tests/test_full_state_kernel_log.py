"""The compiled matrix functions behind the full state's logarithm (refimpl._full_state_kernel).

Checked: the principal logarithm :func:`logm` (inverse scaling and squaring on Denman-Beavers square
roots) and the Frechet derivatives of ``exp`` :func:`expm_frechet` (the abelian refine's Jacobian),
on matrices of the faithful representations the flows use, including the ill-conditioned ones of
Bianchi VI0 (``exp`` of elements whose ``ad`` has real eigenvalues up to 8: entries ``e^8``).

Independent route: mpmath at 40 digits (``mpmath.expm``; the block matrix ``[[X, E], [0, X]]`` for the
derivative), rounded to float64.

Error models (bounds that hold for any backward-stable route, never fitted to this one):

* ``logm``: ``L`` is the exact logarithm of ``G + dG`` with ``|dG|`` of a few ``eps |G|`` per
  operation, amplified by the conditioning of ``exp`` at ``L`` where the square roots lose it; what is
  checked is ``|exp(L) - G| <= 1e3 r eps exp(|L|_2) max(1, |G|)`` (``exp(|L|_2)`` bounds that
  sensitivity: ``|L_exp(L, E)|_2 <= exp(|L|_2) |E|_2``; ``log_batch``'s acceptance test is the same
  with the larger ``|L|_1``), and that ``L`` is the principal one (mpmath's ``logm``), to ``1e-6 |L|``
  (a branch is off by ``2 pi``);
* ``log_state_refined`` (the logarithm of an exponential algebra, its abelian part from the
  integrated ``s``): the answer's residual as the float64 exponential sees it is at most the refine's
  floor ``LOG_REFINE_FLOOR r max(1, |G|)``, so the true residual ``|exp(rho(x)) - G|`` (mpmath) is at
  most that floor plus the float64 exponential's own error at ``x`` (measured against mpmath, not
  modelled); its closed form (``log_state_abelian``, no iteration against the float64 exponential):
  ``x`` is the logarithm to its own rounding, ``10 r eps |x|`` (a few ulp per entry, ``r`` terms
  each), which moves ``exp(rho(x))`` by ``|G|`` times that;
* ``expm_frechet``: the exponential of the block ``Z`` computed by scaling and squaring errs by at
  most ``100 eps exp(|Z|_1) max(1, |exp Z|)`` (the model of tests/test_compiled_any_algebra.py's
  helper check), and ``exp(X)``, ``L(X, E)`` are blocks of it.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tstarg.refimpl import _full_state as fs_mod
from tstarg.refimpl import _full_state_kernel as fk
from tstarg.refimpl._catalogue import bianchi, catalogue
from tstarg.refimpl._representation import representation_for
from tstarg.refimpl.flows import cached_model
from tstarg.refimpl.flows._common import _AbelianPart

EPS = np.finfo(float).eps


def _mp_expm(X):
    with mpmath.workdps(40):
        E = mpmath.expm(mpmath.matrix(X.tolist()))
        return np.array([[complex(v) for v in row] for row in E.tolist()])


def _mp_logm(G):
    with mpmath.workdps(40):
        L = mpmath.logm(mpmath.matrix(G.tolist()))
        return np.array([[complex(v) for v in row] for row in L.tolist()])


def _cases():
    """(label, G): exp of random elements of se(3), su(3), so(4), sl(3, R) and h(3) (unipotent: the
    finite series) in their faithful representations, and of the affine Bianchi VI0 elements ``[[0, a, 2], [a, 0, -1], [0, 0, 0]]``."""
    rng = np.random.default_rng(11)
    out = []
    for name, scale in [
        ("se(3)", 2.0),
        ("su(3)", 1.0),
        ("so(4)", 1.0),
        ("sl(3,R)", 1.0),
        ("h(3)", 3.0),
    ]:
        alg = catalogue(name)
        mats = np.asarray(representation_for(alg).mats)
        for k in range(2):
            X = np.einsum("a,aij->ij", scale * rng.standard_normal(alg.f.shape[0]), mats)
            G = _mp_expm(X)
            out.append((f"{name}-{k}", G if np.iscomplexobj(mats) else G.real.copy()))
    for a in (1.0, 5.6, 8.0):
        X = np.array([[0.0, a, 2.0], [a, 0.0, -1.0], [0.0, 0.0, 0.0]])
        out.append((f"bianchi-{a}", _mp_expm(X).real.copy()))
    return out


CASES = _cases()


@pytest.mark.parametrize("label,G", CASES, ids=[c[0] for c in CASES])
def test_logm_is_the_principal_log_to_its_backward_error(label, G):
    r = G.shape[0]
    L = np.zeros_like(G)
    assert fk.logm(np.ascontiguousarray(G), L)
    assert np.all(np.isfinite(L))
    back = np.max(np.abs(_mp_expm(L) - G))
    cond = np.exp(np.linalg.norm(L, 2))
    assert back <= 1e3 * r * EPS * cond * max(1.0, np.max(np.abs(G))), (back, cond)
    Lr = _mp_logm(G)
    assert np.max(np.abs(L - Lr)) <= 1e-6 * max(1.0, np.max(np.abs(Lr)))


def test_logm_refuses_a_matrix_without_a_real_principal_log():
    """``diag(-1, -2, 1)``: eigenvalues on the negative real axis -- no principal logarithm."""
    L = np.zeros((3, 3))
    assert not fk.logm(np.diag([-1.0, -2.0, 1.0]), L)


@pytest.mark.parametrize("scale", [0.3, 2.0, 6.0])
def test_expm_frechet_against_the_block_exponential(scale):
    rng = np.random.default_rng(int(10 * scale))
    r, m = 3, 2
    X = scale * rng.standard_normal((r, r))
    Es = rng.standard_normal((m, r, r))
    E = np.zeros((r, r))
    L = np.zeros((m, r, r))
    fk.expm_frechet(X, Es, E, L)
    for c in range(m):
        Z = np.zeros((2 * r, 2 * r))
        Z[:r, :r] = Z[r:, r:] = X
        Z[:r, r:] = Es[c]
        EZ = _mp_expm(Z).real
        bound = 100 * EPS * np.exp(np.linalg.norm(Z, 1)) * max(1.0, np.max(np.abs(EZ)))
        assert np.max(np.abs(E - EZ[:r, :r])) <= bound
        assert np.max(np.abs(L[c] - EZ[:r, r:])) <= bound


_VI0 = None


def _vi0():
    """The full-state tables of a Bianchi VI0 model (affine representation, abelian part ``x_3``)."""
    global _VI0
    if _VI0 is None:
        f = np.array(bianchi("VI0").f, dtype=float)
        z = np.zeros((3, 3))
        model = cached_model(f, z, z, np.eye(3), None)
        _VI0 = fs_mod.full_state(model, _AbelianPart)
    return _VI0


@pytest.mark.parametrize("closed", [False, True])
@settings(deadline=None)
@given(
    st.lists(st.floats(-6.0, 6.0), min_size=2, max_size=2),
    st.floats(-6.5, 6.5),
)
@example([5.07794626, -5.40291662], 5.72304174)  # a bench batch row whose log was 500 ulp off
def test_refined_log_reaches_the_exponentials_rounding(closed, xy, s):
    """Bianchi VI0 at ``|x|`` up to ~10 (``|G|`` up to ``e^6.5``): ``log_state_refined`` of
    ``G = exp(rho(x_true))`` (mpmath, rounded) with ``s = x_true_3``. Its ``x`` keeps ``s`` as the
    abelian part (or the logarithm's, within ``ABELIAN_RTOL`` of it) and reproduces ``G`` to the float64 exponential's rounding (module docstring): the
    logarithm alone was hundreds of ulp off in ``x_3`` while within ``ABELIAN_RTOL`` of ``s``, which
    moved ``Ad(exp x)`` by 1.2e-10 and refused bench batch rows. Both routes: ``logm`` and the
    Gauss-Newton refine (``log_state_refined``), and the refine's answer in closed form
    (``log_state_abelian``, what the flows run on Bianchi VI0)."""
    fs = _vi0()
    x_true = np.array([xy[0], xy[1], s])
    X = np.einsum("a,aij->ij", x_true, fs.mats)
    G = np.ascontiguousarray(_mp_expm(X).real[None])
    Ad = np.empty((1, 3, 3))
    fk.ad_batch(G, fs.mats, fs.proj, False, Ad)
    B = np.zeros((1, fs.d))
    B[0, fs.d - 1] = s
    xs, ok, resid = np.empty((1, 3)), np.empty(1, np.bool_), np.empty(1)
    if closed:
        done = fk.log_state_abelian(
            B, G, Ad, fs.mats, fs.proj, fs.adt, fs.adc, *fs.abelian_tables[1::2], xs, ok, resid
        )
    else:
        done = fk.log_state_refined(
            B, G, Ad, fs.mats, fs.proj, fs.adt, fs.adc, *fs.abelian_tables, fs_mod.ABELIAN_RTOL,
            xs, ok, resid,
            fk.LOG_GENERAL,
        )  # fmt: skip
    assert done and ok[0]
    x = xs[0]
    assert abs(x[2] - s) <= fs_mod.ABELIAN_RTOL * max(1.0, abs(s))  # s kept, or the log's within
    Xx = np.einsum("a,aij->ij", x, fs.mats)
    exact = _mp_expm(Xx).real
    seen = np.empty((3, 3))
    fk.expm(Xx, seen)
    exp_err = np.max(np.abs(seen - exact))  # the float64 exponential's own error at x
    floor = fk.LOG_REFINE_FLOOR * 3 * max(1.0, np.max(np.abs(G)))
    if closed:
        # no iteration against the float64 exponential: x is G's logarithm to its own rounding, a
        # few ulp per entry (r terms each) of |x|, which moves exp(rho(x)) by |G| |dx|
        floor = 10 * 3 * EPS * max(1.0, np.max(np.abs(G))) * max(1.0, np.max(np.abs(x)))
    res = np.max(np.abs(exact - G[0]))
    assert res <= floor + exp_err, (res, floor, exp_err)


def test_closed_form_abelian_log_hands_an_inconsistent_row_to_the_caller():
    """``s`` 1e-6 off the abelian part of ``G`` (an answer whose ``s`` and ``G`` disagree):
    ``exp(rho(x))`` misses ``G`` by ~1e-6 |G|, far over the acceptance test's ``1e3 r eps cond |G|``,
    so ``log_state_abelian`` leaves that row to the caller (``ok`` False, not final), and
    ``_full_state._log_complete`` then gives ``G``'s own logarithm (the refine keeps the log's ``x``
    when the fit with ``s`` does not beat it) with a residual ``|Ad(exp x) - Ad(g)|`` that covers what
    ``x`` misses (mpmath's ``Ad(exp x)``, to its float64 rounding ``100 eps |Ad|``)."""
    fs = _vi0()
    x_true = np.array([0.4, -0.7, 1.3])
    G = np.ascontiguousarray(_mp_expm(np.einsum("a,aij->ij", x_true, fs.mats)).real[None])
    Ad = np.empty((1, 3, 3))
    fk.ad_batch(G, fs.mats, fs.proj, False, Ad)
    B = np.zeros((1, fs.d))
    B[0, fs.d - 1] = x_true[2] + 1e-6
    xs, ok, resid = np.empty((1, 3)), np.empty(1, np.bool_), np.empty(1)
    assert not fk.log_state_abelian(
        B, G, Ad, fs.mats, fs.proj, fs.adt, fs.adc, *fs.abelian_tables[1::2], xs, ok, resid
    )
    assert not ok[0]
    fs_mod._log_complete(fs, B, G[0:1], Ad, xs, ok, resid)
    X = np.einsum("a,aij->ij", xs[0], fs.mats)
    E = _mp_expm(X).real
    Ax = np.empty((1, 3, 3))
    fk.ad_batch(np.ascontiguousarray(E[None]), fs.mats, fs.proj, False, Ax)
    miss = np.max(np.abs(Ax[0] - Ad[0]))
    assert np.isfinite(resid[0])
    assert miss <= resid[0] + 100 * EPS * max(1.0, np.max(np.abs(Ad))), (miss, resid[0])
    assert np.max(np.abs(xs[0] - x_true)) <= 1e-9  # G's logarithm, not the 1e-6-off s


# ---------------------------------------------------------------------- Ad(g) as a sparse sum
def _mp_ad(G, mats, proj):
    """``Ad(g)`` at 40 digits: ``G E_b G^-1`` (mpmath's inverse) projected by ``proj`` (real parts,
    then imaginary parts), rounded to float64 at the end."""
    n, r, _ = mats.shape
    cplx = proj.shape[1] == 2 * r * r
    with mpmath.workdps(40):
        Gm = mpmath.matrix(G.tolist())
        Gi = Gm**-1
        out = np.empty((n, n))
        for b in range(n):
            X = Gm * mpmath.matrix(mats[b].tolist()) * Gi
            v = [X[i, j] for i in range(r) for j in range(r)]
            vec = [mpmath.re(z) for z in v] + ([mpmath.im(z) for z in v] if cplx else [])
            for a in range(n):
                out[a, b] = float(
                    mpmath.fsum(mpmath.mpf(float(p)) * z for p, z in zip(proj[a], vec))
                )
    return out


AD_NAMES = ["se(3)", "su(3)", "so(4)", "sl(3,R)", "h(5)", "Bianchi VI0", "se(2)", "su(2)", "aff(1)"]


def _ad_cases(name):
    """``(mats, proj, G)``: three exponentials of random elements at two scales in ``name``'s faithful
    representation, by mpmath, and on Bianchi III one of ``x = (0, 0, 12)`` (a 2 x 2 block with
    eigenvalues ``e^12`` and 1 nearly parallel rows after a shear: ``kappa(G)`` ~1e10, ``Ad``
    entries of order 1 from sums of order 1e10)."""
    alg = catalogue(name) if name != "Bianchi III" else bianchi("III")
    mats = np.ascontiguousarray(representation_for(alg).mats)
    n = mats.shape[0]
    proj = np.ascontiguousarray(fs_mod._projector(mats))
    rng = np.random.default_rng(7)
    xs = [s * rng.standard_normal(n) for s in (0.3, 0.3, 0.3, 1.5, 1.5, 1.5)]
    if name == "Bianchi III":
        xs.append(np.array([6.0, 0.5, 12.0]))
    G = np.stack([_mp_expm(np.einsum("a,aij->ij", v, mats)) for v in xs])
    G = np.ascontiguousarray(G if np.iscomplexobj(mats) else G.real)
    return mats, proj, G


@pytest.mark.parametrize("name", [*AD_NAMES, "Bianchi III"])
def test_sparse_ad_is_the_dense_ad_and_within_its_error_model(name):
    """:func:`ad_sparse` (the pair's and the residual's ``Ad``) is the dense :func:`ad_batch` bit for
    bit (the same sums in the same order without their exact-zero terms), and both are ``Ad(g)`` at 40
    digits within the error model of a backward-stable route: ``G^-1`` is the inverse of a matrix
    within a few ``r eps |G|`` of ``G`` (Gauss-Jordan with pivoting), which moves it by ``r eps
    kappa(G) |G^-1|`` (``kappa = |G|_1 |G^-1|_1``), and every entry of ``Ad`` is a sum of at most
    ``2 r^2`` products bounded by ``S = |proj| vec(|G| |E_b| |G^-1|)`` (numpy), each and their sum
    rounded to a few ``eps``: bound ``10 r^2 eps kappa max(1, S)``."""
    mats, proj, G = _ad_cases(name)
    n, r, _ = mats.shape
    adt, adc = fk.ad_table(mats, proj)
    N = G.shape[0]
    sparse, dense = np.empty((N, n, n)), np.empty((N, n, n))
    fk.ad_sparse(G, adt, adc, sparse)
    fk.ad_batch(G, mats, proj, np.iscomplexobj(mats), dense)
    assert np.all(np.isfinite(sparse))
    assert np.array_equal(sparse, dense)
    for k in range(N):
        exact = _mp_ad(G[k], mats, proj)
        Gi = np.linalg.inv(G[k])
        kappa = np.linalg.norm(G[k], 1) * np.linalg.norm(Gi, 1)
        mag = np.stack([np.abs(G[k]) @ np.abs(mats[b]) @ np.abs(Gi) for b in range(n)])
        vec = mag.reshape(n, -1)
        if np.iscomplexobj(mats):
            vec = np.concatenate([vec, vec], axis=1)
        S = np.abs(proj) @ vec.T  # (a, b)
        bound = 10 * r * r * EPS * kappa * max(1.0, S.max())
        assert np.max(np.abs(sparse[k] - exact)) <= bound, (
            name,
            k,
            np.max(np.abs(sparse[k] - exact)),
            bound,
        )


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_sparse_ad_of_a_non_finite_or_singular_g_is_nan(bad):
    """A ``G`` with one entry NaN or infinite (one the sum never reads among them), or singular: every
    ``Ad`` entry NaN (so the estimate and the residual refuse the row), as the dense route gives for
    a failed inverse."""
    rep = representation_for(catalogue("Bianchi VI0"))
    mats = np.ascontiguousarray(rep.mats.real)
    proj = np.ascontiguousarray(fs_mod._projector(mats))
    adt, adc = fk.ad_table(mats, proj)
    G = np.stack([np.eye(3)] * 11)
    for k in range(9):
        G[k, k // 3, k % 3] = bad
    G[9] = 0.0  # singular
    G[10, 2, 2] = 1e-320  # a subnormal pivot
    out = np.zeros((11, 3, 3))
    fk.ad_sparse(np.ascontiguousarray(G), adt, adc, out)
    for k in range(11):  # the subnormal pivot's inverse overflows: G^-1 not finite
        assert np.all(np.isnan(out[k])), (k, out[k])


@pytest.mark.parametrize("name", ["so(4)", "sl(3,R)"])
def test_sparse_ad_on_a_dense_basis(name):
    """A random basis (every ``E_b`` and every row of ``proj`` dense, sl(3, R) without a zero entry):
    :func:`ad_sparse` through its tables is :func:`ad_batch` bit for bit."""
    rep = representation_for(catalogue(name))
    mats = np.asarray(rep.mats.real)
    n = mats.shape[0]
    T = np.random.default_rng(5).standard_normal((n, n))
    mats = np.ascontiguousarray(np.einsum("ab,bij->aij", T, mats))
    proj = np.ascontiguousarray(fs_mod._projector(mats))
    adt, adc = fk.ad_table(mats, proj)
    x = 0.4 * np.random.default_rng(6).standard_normal((4, n))
    G = np.ascontiguousarray(np.stack([_mp_expm(np.einsum("a,aij->ij", v, mats)).real for v in x]))
    sparse, dense = np.empty((4, n, n)), np.empty((4, n, n))
    fk.ad_sparse(G, adt, adc, sparse)
    fk.ad_batch(G, mats, proj, False, dense)
    assert np.all(np.isfinite(sparse)) and np.array_equal(sparse, dense)
