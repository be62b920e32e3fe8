"""Faithful representations built from structure constants (refimpl._representation).

Homomorphism ``[rho(a), rho(b)] = f^m_ab rho(e_m)`` and injectivity, exactly (sympy rationals)
where the constants are rational, on every catalogue algebra, on the hard cases (centre meeting
[g, g]: Heisenberg, the oscillator algebra, h3 (+) su(2) in a mixed basis) and on Hypothesis-drawn
algebras; negative controls; the logarithm's documented choices.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import scipy.linalg
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

from tstarg.properties.strategies import basis_changes, lie_algebras
from tstarg.refimpl import LieAlgebra
from tstarg.refimpl._catalogue import CATALOGUE_NAMES, bianchi, catalogue, heisenberg, su2
from tstarg.refimpl._representation import (
    RepresentationError,
    check_representation,
    faithful_representation,
    representation_for,
)

EPS = np.finfo(float).eps


def _oscillator() -> LieAlgebra:
    """``[N, a] = b``, ``[N, b] = -a``, ``[a, b] = c``: non-nilpotent, centre ``c`` inside ``[g, g]``."""
    f = np.zeros((4, 4, 4), dtype=int)
    for i, j, m, v in ((0, 1, 2, 1), (0, 2, 1, -1), (1, 2, 3, 1)):
        f[m, i, j], f[m, j, i] = v, -v
    return LieAlgebra.from_structure_constants(f, name="oscillator")


def _h3_plus_su2_mixed() -> LieAlgebra:
    C = (
        sympy.Matrix(
            [
                [1, 0, 0, 1, 0, 0],
                [0, 1, 0, 0, 1, 0],
                [1, 0, 1, 0, 0, 1],
                [0, 1, 0, 1, 0, 0],
                [0, 0, 1, 0, 1, 0],
                [1, 0, 0, 0, 0, 1],
            ]
        )
        / 2
        + sympy.eye(6) / 2
    )
    return (
        heisenberg(1)
        .direct_sum(su2())
        .change_basis(np.array(C.tolist(), dtype=object), name="h3+su2 mixed")
    )


def _check_exact(alg, rep):
    """Independent exact check (not check_representation): commutators against f_exact in sympy."""
    E = [sympy.Matrix(m.tolist()) for m in rep.exact]
    n = alg.dim
    fe = alg.f_exact
    for a in range(n):
        for b in range(n):
            rhs = sum((fe[m, a, b] * E[m] for m in range(n)), sympy.zeros(*E[0].shape))
            assert (E[a] * E[b] - E[b] * E[a] - rhs).is_zero_matrix, (alg.name, a, b)
    assert sympy.Matrix([list(m) for m in E]).rank() == n, alg.name


@pytest.mark.parametrize("name", CATALOGUE_NAMES)
def test_every_catalogue_algebra_gets_a_faithful_representation(name):
    alg = catalogue(name)
    rep = faithful_representation(alg.f)
    check_representation(alg.f, rep.mats)
    if alg.is_rational:
        assert rep.exact is not None
        _check_exact(alg, rep)
    centre_trivial = np.linalg.matrix_rank(alg.f.transpose(0, 2, 1).reshape(-1, alg.dim)) == alg.dim
    assert (rep.kind == "adjoint") == centre_trivial


@pytest.mark.parametrize("make", [_oscillator, _h3_plus_su2_mixed, lambda: heisenberg(2)])
def test_centre_meeting_the_derived_algebra(make):
    """The cases the adjoint representation (plus the abelianisation) cannot cover."""
    alg = make()
    rep = faithful_representation(alg.f)
    assert rep.kind in ("nilpotent", "adjoint+ideal", "adjoint+ideal+abelian")
    _check_exact(alg, rep)
    # the centre is represented injectively (ad kills it): rho(z) != 0 for a central z
    z = rep.centre[:, 0].astype(float)
    assert np.max(np.abs(np.einsum("a,aij->ij", z, rep.mats))) > 0.5 * np.max(np.abs(z))


def test_float_constants_irrational_basis_change():
    """The float path (constants that are not small rationals) on the oscillator algebra in an irrational basis."""
    alg = _oscillator()
    C = np.eye(4) + np.sqrt(2) / 7 * np.arange(16).reshape(4, 4) % 1.0
    Ci = np.linalg.inv(C)
    f = np.einsum("ma,bi,cj,abc->mij", Ci, C, C, alg.f)
    rep = faithful_representation(f)
    assert rep.exact is None and rep.kind.startswith("adjoint+ideal")
    check_representation(f, rep.mats)


@settings(max_examples=12, deadline=None)
@given(alg=lie_algebras(max_dim=5))
def test_random_algebras(alg):
    rep = faithful_representation(alg)
    check_representation(alg.f, rep.mats)
    if alg.is_rational:
        _check_exact(alg, rep)


@settings(max_examples=6, deadline=None)
@given(data=st.data())
def test_random_basis_changes_of_the_hard_cases(data):
    alg = data.draw(st.sampled_from([_oscillator(), heisenberg(1)]))
    c = data.draw(basis_changes(alg.dim))
    alg2 = alg.change_basis(c)
    rep = faithful_representation(alg2)
    _check_exact(alg2, rep)


def test_negative_controls_are_rejected():
    """A non-homomorphic map and a non-injective one are refused, in float and exactly."""
    alg = _oscillator()
    rep = faithful_representation(alg.f)
    bad = rep.mats.copy()
    bad[0] = bad[0] + 1e-3 * np.eye(bad.shape[1])[::-1]  # breaks [rho(N), rho(a)] = rho(b)
    with pytest.raises(RepresentationError, match="not a homomorphism"):
        check_representation(alg.f, bad)
    adj = np.array([alg.f[:, a, :] for a in range(4)], dtype=float)  # ad kills the centre c
    with pytest.raises(RepresentationError, match="not injective"):
        check_representation(alg.f, adj)
    with pytest.raises(RepresentationError, match="not injective"):
        check_representation(
            alg.f,
            None,
            exact=np.array(
                [sympy.Matrix(m.tolist()) for m in adj.astype(int)], dtype=object
            ).reshape(adj.shape),
        )
    ex = rep.exact.copy()
    ex[1] = ex[1] * 2
    with pytest.raises(RepresentationError, match="not a homomorphism"):
        check_representation(alg.f, None, exact=ex)


def test_cached_per_algebra():
    f = _oscillator().f
    assert faithful_representation(f) is faithful_representation(f.copy())


@settings(max_examples=10, deadline=None)
@given(x=st.lists(st.floats(-4, 4), min_size=4, max_size=4))
def test_log_inverts_exp_oscillator(x):
    """exp(log g) = g; and for small x (principal strip of rho) log(exp x) = x."""
    alg = _oscillator()
    rep = faithful_representation(alg.f)
    x = np.array(x)
    G = rep.exp(x)
    Ad = scipy.linalg.expm(np.einsum("a,mab->mb", x, alg.f))
    y = rep.log(G, Ad)
    # expm / logm rounding: c eps cond scale, cond ~ e^{|rho(x)|_1}
    cond = np.exp(np.linalg.norm(rep.matrix(x), 1))
    assert np.max(np.abs(rep.exp(y) - G)) <= 1e4 * EPS * cond * max(1.0, np.max(np.abs(G)))
    if np.max(np.abs(np.linalg.eigvals(rep.matrix(x)).imag)) < 3.0:
        assert np.max(np.abs(y - x)) <= 1e4 * EPS * cond * max(1.0, np.max(np.abs(x)))


def test_log_on_the_cut_locus():
    """so(3) in another basis (adjoint representation): a rotation by pi has two real logarithms
    +-pi n; the documented choice returns one of them, with exp(x) = g and |Im eig ad_x| = pi."""
    alg = su2().change_basis(np.array([[1, 1, 0], [0, 1, 0], [0, 0, 2]]))
    rep = faithful_representation(alg.f)
    assert rep.kind == "adjoint"
    axis = np.array([0.3, -0.5, 0.2])
    adx = np.einsum("a,mab->mb", axis, alg.f)
    r = np.max(np.abs(np.linalg.eigvals(adx).imag))
    x = np.pi / r * axis
    G = rep.exp(x)
    assert np.min(np.abs(np.linalg.eigvals(G) + 1)) < 1e-12  # on the cut locus
    y = rep.log(G, G)
    assert np.max(np.abs(rep.exp(y) - G)) <= 1e4 * EPS * np.linalg.norm(G, 1)
    assert abs(np.max(np.abs(np.linalg.eigvals(rep.matrix(y)).imag)) - np.pi) < 1e-6
    assert min(np.max(np.abs(y - x)), np.max(np.abs(y + x))) < 1e-6


def test_log_far_from_identity_bianchi_vii_h():
    """Bianchi VII_h(h=4) at ``|ad_x|_1 = 34`` (where a reference flow ended on CI seed 29477): the
    principal ``logm`` of ``Ad(g)``, projected on the algebra, is off by ``|exp(x') - G|_1 = 2.9``, and
    the old acceptance bound ``exp(|ad_x|_1) = 5e13`` let it through. The float64 and the mpmath
    logarithm must both return an ``x'`` with ``exp(x') = g``: checked against ``G = exp(ad_x)`` built
    at 40 digits from the ``x`` we started from (exact rational constants: h = 4 gives sqrt(h) = 2).
    Error models: float64 ``1e3 eps |ad_x|_1 * 50`` (backward-stable log, exp spreads an error by at
    most ~50 here, the sampled ``max_s |e^(s ad_x)| |e^((1-s) ad_x)|``); mpmath at 30 digits
    ``10^-22``."""
    alg = bianchi("VII_h", h=4)
    rep = representation_for(alg)
    x = [-2.9455118609080655, 8.878138628494874, 7.01337288517639]
    n = len(x)

    def exact_const(v):
        r = sympy.Rational(v)
        return mpmath.mpf(int(r.p)) / int(r.q)

    with mpmath.workdps(40):
        Fm = [mpmath.matrix([[exact_const(alg.f_exact[m, a, b]) for b in range(n)] for a in range(n)])
              for m in range(n)]  # fmt: skip
        adx = mpmath.matrix(
            [
                [mpmath.fsum(x[a] * Fm[m][a, b] for a in range(n)) for b in range(n)]
                for m in range(n)
            ]
        )
        G = mpmath.expm(adx)
    Gf = np.array(G.tolist(), dtype=float)
    if rep.kind == "adjoint":
        y = rep.log(Gf, Gf)
        ady = np.einsum("a,mab->mb", y, np.asarray(alg.f, dtype=float))
        assert np.max(np.abs(scipy.linalg.expm(ady) - Gf)) <= 1e3 * EPS * 34 * 50, y
    with mpmath.workdps(30):
        y = rep.mp_log(G, G, Fm)
        res = mpmath.mnorm(rep.mp_exp(y, Fm) - G, 1)
        assert res <= mpmath.mpf(10) ** -22, (list(y), res)
