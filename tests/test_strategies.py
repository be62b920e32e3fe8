"""The strategies draw what they promise: valid Lie algebras of every family (class B, solvable,
nilpotent, basis-changed, not only so(3) look-alikes), cocycles of the requested class,
TOML-describable scenes, and broken data for the negative controls; bad arguments raise."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
import sympy
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from tstarg.properties import strategies as S
from tstarg.refimpl import LieAlgebra, check_cocycle, solve_coboundary

EPS = float(np.finfo(float).eps)


def _killing(alg):
    return sympy.Matrix(np.einsum("man,nbm->ab", alg.f_exact, alg.f_exact).tolist())


def _derived_basis(alg):
    """A basis of [g, g] as exact columns (independent of the float ranks in strategies)."""
    n = alg.dim
    cols = sympy.Matrix(
        [[alg.f_exact[m, a, b] for a in range(n) for b in range(n)] for m in range(n)]
    )
    return cols.columnspace()


@given(S.lie_algebras())
def test_lie_algebras_are_lie_algebras(alg):
    """Every draw satisfies the Jacobi identity by a residual computed here from the float
    constants (independent of the exact validator that built it), to c * eps * max|f|^2."""
    assert isinstance(alg, LieAlgebra) and alg.is_exact
    f = np.asarray(alg.f, dtype=float)
    ff = np.einsum("mab,bcd->macd", f, f)  # f^m_ab f^b_cd: [[e_c, e_d], e_a] components
    jac = np.einsum("macd->macd", ff) + np.einsum("mdac->macd", ff) + np.einsum("mcda->macd", ff)
    scale = max(1.0, float(np.max(np.abs(f)))) ** 2
    tol = 8 * alg.dim * EPS * scale  # error model: 3 sums of n products, each rounded once
    assert np.all(np.isfinite(jac)) and float(np.max(np.abs(jac))) <= tol


@given(S.lie_algebras(solvable=True, max_dim=5))
def test_solvable_filter_cartan_criterion(alg):
    """Cartan's criterion: g is solvable iff the Killing form vanishes on g x [g, g]."""
    K = _killing(alg)
    for v in _derived_basis(alg):
        assert (K * v).is_zero_matrix


@given(S.lie_algebras(nilpotent=True, max_dim=5))
def test_nilpotent_filter_engel(alg):
    """Engel: in a nilpotent algebra every ad_x is nilpotent, ad_x^n = 0 (checked on the basis and a sum)."""
    n = alg.dim
    for x in list(np.eye(n, dtype=int)) + [np.ones(n, dtype=int)]:
        ad = alg.ad_exact(list(x))
        assert (ad**n).is_zero_matrix


@given(S.lie_algebras(semisimple=True))
def test_semisimple_filter_perfect(alg):
    """A semisimple algebra has a non-degenerate Killing form and is perfect: [g, g] = g."""
    assert _killing(alg).det() != 0
    assert len(_derived_basis(alg)) == alg.dim


def test_families_are_all_drawn_class_b_often():
    """200 draws cover every family and class B Bianchi algebras are frequent (the so(3) trap)."""
    seen = Counter()

    @seed(1)
    @settings(
        max_examples=200, database=None, deadline=None, suppress_health_check=list(HealthCheck)
    )
    @given(S.lie_algebras())
    def collect(alg):
        tags = alg.tags
        key = (
            "changed"
            if "[C=" in alg.name
            else "direct_sum"
            if "direct_sum" in tags
            else "class B"
            if "class B" in tags
            else "class A"
            if "class A" in tags
            else "nilpotent"
            if "nilpotent" in tags
            else "semidirect"
            if "semidirect" in tags
            else "solvable"
            if alg.name.startswith("b(")
            else "catalogue"
        )
        seen[key] += 1

    collect()
    total = sum(seen.values())
    for key in (
        "class B",
        "class A",
        "nilpotent",
        "semidirect",
        "direct_sum",
        "changed",
        "solvable",
    ):
        assert seen[key] > 0, f"family {key} never drawn: {dict(seen)}"
    assert seen["class B"] >= 0.08 * total, f"class B Bianchi drawn too rarely: {dict(seen)}"


@given(st.data())
def test_basis_changes_are_well_conditioned(data):
    """C = D L U: det C = prod D != 0 and cond(C) within the stated bound (1 + n)^(2n) * 4."""
    n = data.draw(st.integers(1, 6))
    C = data.draw(S.basis_changes(n))
    Cf = np.array(C, dtype=float)
    assert sympy.Matrix(C.tolist()).det() != 0
    assert np.linalg.cond(Cf) <= (1 + n) ** (2 * n) * 4


@given(st.data())
def test_cocycles_classes(data):
    """coboundary=True gives -xi.f (solvable for xi); coboundary=False a cocycle with no xi (zeven1, zeven3)."""
    alg = data.draw(S.lie_algebras(max_dim=4))
    th = data.draw(S.cocycles(alg, coboundary=True))
    check_cocycle(alg, th)
    xi = solve_coboundary(alg, th)
    rebuilt = -np.einsum("m,mab->ab", np.array(xi, dtype=object), alg.f_exact)
    assert all(sympy.simplify(v) == 0 for v in (rebuilt - th).flat)
    if len(S.cocycle_basis(alg)) > len(S.coboundary_basis(alg)):
        th2 = data.draw(S.cocycles(alg, coboundary=False))
        check_cocycle(alg, th2)
        with pytest.raises(ValueError, match="not a coboundary"):
            solve_coboundary(alg, th2)


@given(st.data())
def test_negative_control_strategies_are_broken(data):
    """jacobi_breaking_constants break Jacobi (LieAlgebra refuses them); non_cocycles break zeven1."""
    f = data.draw(S.jacobi_breaking_constants(n=3))
    with pytest.raises(ValueError, match="Jacobi"):
        LieAlgebra.from_structure_constants(f)
    alg = data.draw(
        S.lie_algebras(max_dim=4).filter(
            lambda a: len(S.cocycle_basis(a)) < a.dim * (a.dim - 1) // 2
        )
    )
    th = data.draw(S.non_cocycles(alg))
    with pytest.raises(ValueError, match="not a 2-cocycle"):
        check_cocycle(alg, th)


def _toml_value_ok(v) -> bool:
    if isinstance(v, dict):
        return all(isinstance(k, str) and _toml_value_ok(x) for k, x in v.items())
    if isinstance(v, list):
        return all(_toml_value_ok(x) for x in v)
    if isinstance(v, float):
        return math.isfinite(v)
    return isinstance(v, (str, int)) and not isinstance(v, bool)


@given(S.scenes(batch=None) | S.scenes(batch=True))
def test_scenes_are_toml_describable(scene):
    """A scene is a plain dict of TOML types (no None, finite floats) that the scene loader accepts,
    with the drawn data intact (cocycle Theta, antisymmetric Upsilon, SPD inertia)."""
    parse_scene = pytest.importorskip("tstarg.refimpl.flows").parse_scene
    assert _toml_value_ok(scene)
    sc = parse_scene(scene)
    n = sc.f.shape[0]
    alg = LieAlgebra.from_structure_constants(sc.f)
    check_cocycle(alg, sc.theta)
    assert np.array_equal(sc.upsilon, -sc.upsilon.T)
    assert np.array_equal(sc.inertia, sc.inertia.T) and np.all(np.linalg.eigvalsh(sc.inertia) > 0)
    assert sc.x0.shape[-1] == n and sc.pi0.shape == sc.x0.shape


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: S.lie_algebras(max_dim=0), "max_dim"),
        (lambda: S.lie_algebras(min_dim=4, max_dim=3), "max_dim"),
        (lambda: S.lie_algebras(semisimple=True, solvable=True), "semisimple"),
        (lambda: S.lie_algebras(semisimple="yes"), "semisimple"),
        (lambda: S.lie_algebras(families=["so(3) only"]), "unknown families"),
        (lambda: S.lie_algebras(semisimple=True, max_dim=2), "max_dim"),
        (lambda: S.cocycles("su(2)"), "LieAlgebra"),
        (lambda: S.cocycles(S.catalogue("su(2)"), coboundary=False), "H\\^2 = 0"),
        (lambda: S.non_cocycles(S.catalogue("R^3")), "every 2-form"),
        (lambda: S.basis_changes(0), "n must be"),
        (lambda: S.points(S.catalogue("su(2)"), regime="nowhere"), "regime"),
        (lambda: S.points(S.catalogue("su(2)"), regime="near_degenerate"), "theta and upsilon"),
        (lambda: S.upsilons(1, zero=False), "n >= 2"),
        (lambda: S.scenes(names=["so(7)"]), "unknown algebra"),
        (lambda: S.jacobi_breaking_constants(n=2), "n must be"),
    ],
)
def test_bad_arguments_raise(call, match):
    """Strategies validate their arguments with a ValueError naming the argument."""
    with pytest.raises(ValueError, match=match):
        call()


@given(st.data())
def test_points_regimes_deliver_their_conditioning(data):
    """near_degenerate: ||Phi^-1|| max(1, ||S|| ||U||) in [1e2, 1e12] (recomputed at 30 digits); near_chart_boundary:
    ||ad_x||_F / 2 pi in {0.6, 0.8, 0.9}; generic: |x| <= 0.8, |pi| <= 2 per component."""
    import mpmath

    m = data.draw(
        S.models(algebras=S.lie_algebras(max_dim=4).filter(lambda a: a.f.any()), upsilon_zero=False)
    )
    alg = m["algebra"]
    th, up = np.array(m["theta"], dtype=float), np.array(m["upsilon"], dtype=float)
    x, pi = data.draw(S.points(alg, m["theta"], m["upsilon"], regime="near_degenerate"))
    with mpmath.workdps(30):
        Sm = mpmath.matrix(np.einsum("m,mab->ab", pi, alg.f).tolist()) - mpmath.matrix(th.tolist())
        Um = mpmath.matrix(up.tolist())
        Phi = mpmath.eye(alg.dim) + Sm * Um
        smin = min(mpmath.svd_r(Phi, compute_uv=False))
        data_norm = max(
            1, max(mpmath.svd_r(Sm, compute_uv=False)) * max(mpmath.svd_r(Um, compute_uv=False))
        )
        kappa = float(data_norm / smin)
    # error model: the strategy measured kappa in float64, off by ~ n eps kappa relative (Phi's
    # entries rounded, perturbation of the smallest singular value): slack 8 n eps 1e12
    slack = 8 * alg.dim * EPS * 1e12
    assert 1e2 * (1 - slack) <= kappa <= 1e12 * (1 + slack), kappa
    x, _ = data.draw(S.points(alg, regime="near_chart_boundary"))
    rho = np.linalg.norm(alg.ad(x)) / (2 * np.pi)
    # error model: x is scaled by rho 2 pi / ||ad_x||; a norm and a scaling, each a few n eps relative
    # a direction central up to rounding is returned unscaled: its ad_x is at most the strategy's
    # central tolerance (4 n^2 eps max|f| max|x|, the rounding of a sum of n products)
    central = np.max(np.abs(alg.ad(x))) <= S.central_tolerance(alg) * np.max(np.abs(x))
    assert min(abs(rho - r) for r in (0.6, 0.8, 0.9)) <= 16 * alg.dim * EPS or central
    x, pi = data.draw(S.points(alg, regime="generic"))
    assert np.all(np.abs(x) <= 0.8) and np.all(np.abs(pi) <= 2)
