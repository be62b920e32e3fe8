"""Lie algebras: every catalogue entry is a Lie algebra, its representation is faithful and
consistent, and the constructions (change of basis, direct sum, semidirect product) are correct."""

from __future__ import annotations

import numpy as np
import pytest
import sympy

from tstarg.refimpl import (
    CATALOGUE_NAMES,
    LieAlgebra,
    abelian,
    bianchi,
    catalogue,
    heisenberg,
    se3,
    so3_other_basis,
    su2,
    su3,
)
from tstarg.refimpl._algebra import jacobi_residual

SEMISIMPLE = {
    "su(2)",
    "so(3)[other basis]",
    "sl(2,R)",
    "Bianchi VIII",
    "Bianchi IX",
    "so(4)",
    "su(3)",
    "sl(3,R)",
}


def _jacobi_by_hand(f) -> list:
    """``[[e_a, e_b], e_c] + [[e_b, e_c], e_a] + [[e_c, e_a], e_b]`` for a < b < c, from the bracket
    ``[e_a, e_b] = f^m_ab e_m`` written out here (independent of refimpl's jacobi_residual)."""
    n = f.shape[0]

    def br(u, v):
        return [
            sympy.expand(sum(f[m, a, b] * u[a] * v[b] for a in range(n) for b in range(n)))
            for m in range(n)
        ]

    e = [[sympy.Integer(int(i == k)) for i in range(n)] for k in range(n)]
    out = []
    for a in range(n):
        for b in range(a + 1, n):
            for c in range(b + 1, n):
                cyc = [
                    x + y + z
                    for x, y, z in zip(
                        br(br(e[a], e[b]), e[c]), br(br(e[b], e[c]), e[a]), br(br(e[c], e[a]), e[b])
                    )
                ]
                out.extend(sympy.simplify(v) for v in cyc)
    return out


@pytest.mark.parametrize("name", CATALOGUE_NAMES)
def test_validator_agrees_with_jacobi_by_hand(name):
    """The catalogue's constants satisfy Jacobi by a hand-written cyclic sum, and the validator of
    LieAlgebra rejects the same constants with one bracket perturbed exactly when that sum says
    Jacobi breaks (so the validator is neither bypassed nor too lax)."""
    alg = catalogue(name)
    f = alg.f_exact
    assert all(v == 0 for v in _jacobi_by_hand(f))
    n = alg.dim
    if n < 3:
        return  # every antisymmetric bracket on a space of dimension <= 2 satisfies Jacobi
    rejected = 0
    for kicks in [[(0, 0, 1)], [(n - 1, 1, 2)], [(1, 0, n - 1)], [(0, 0, 1), (1, 1, 2)]]:
        g = f.copy()
        for k, (m, a, b) in enumerate(kicks):
            g[m, a, b] = g[m, a, b] + sympy.Rational(1, 3 + 2 * k)
            g[m, b, a] = -g[m, a, b]
        breaks = any(v != 0 for v in _jacobi_by_hand(g))
        try:
            LieAlgebra.from_structure_constants(g, name=f"{name} perturbed")
            accepted = True
        except ValueError:
            accepted = False
        assert accepted == (not breaks), (
            f"{name}: validator {'accepted' if accepted else 'rejected'} f + {kicks}"
        )
        rejected += not accepted
    assert rejected >= 1, f"{name}: no perturbation broke Jacobi; the negative control did not bite"


@pytest.mark.parametrize("name", [n for n in CATALOGUE_NAMES if catalogue(n).rep is not None])
def test_representation_reproduces_structure_constants(name):
    """[E_a, E_b] = f^m_ab E_m, recomputed here in floating point from the matrices."""
    alg = catalogue(name)
    E = np.asarray(alg.rep)
    lhs = np.einsum("aij,bjk->abik", E, E) - np.einsum("bij,ajk->abik", E, E)
    rhs = np.einsum("mab,mik->abik", alg.f, E)
    # error model: entries are sums of d products of O(1) numbers: 8 d eps.
    assert np.max(np.abs(lhs - rhs)) <= 8 * E.shape[1] * np.finfo(float).eps


@pytest.mark.parametrize("name", CATALOGUE_NAMES)
def test_semisimplicity_matches_classification(name):
    """Cartan's criterion agrees with the known classification of each catalogue entry."""
    alg = catalogue(name)
    assert alg.is_semisimple() == (name in SEMISIMPLE)


def test_killing_forms_published():
    """su(2): eta = -2 delta (paper, section cinq); su(3) in the Gell-Mann basis: -3 delta."""
    assert np.array_equal(su2().killing(), -2 * np.eye(3))
    assert np.allclose(su3().killing(), -3 * np.eye(8), atol=1e-14, rtol=0)


def test_structure_constants_su2_and_su3_textbook():
    """su(2) has f = epsilon (docs/conventions.md); su(3) has f_123 = 1, f_147 = 1/2, f_458 = sqrt(3)/2."""
    f = su2().f
    assert f[2, 0, 1] == 1 and f[0, 1, 2] == 1 and f[1, 2, 0] == 1 and f[2, 1, 0] == -1
    g = su3().f_exact  # 0-based: f^c_ab
    assert (
        g[2, 0, 1] == 1 and g[6, 0, 3] == sympy.Rational(1, 2) and g[7, 3, 4] == sympy.sqrt(3) / 2
    )


def test_change_of_basis_is_isomorphism():
    """so(3) in another basis: Killing form transforms as C^T K C, Jacobi still holds exactly."""
    base = su2()
    c = [[1, 0, 2], [1, 1, 0], [0, 0, 1]]
    other = base.change_basis(c)
    C = np.array(c, dtype=float)
    assert np.allclose(other.killing(), C.T @ base.killing() @ C, atol=1e-12, rtol=0)
    assert all(sympy.simplify(v) == 0 for v in jacobi_residual(other.f_exact).flat)
    assert so3_other_basis().is_semisimple()


def test_semidirect_so3_R3_is_se3():
    """so(3) |x R^3 with the defining representation has the constants of se(3)."""
    eps = su2().f
    rho = [-eps[a] for a in range(3)]  # (L_a)_bc = -eps_abc
    rho_exact = [[[int(v) for v in row] for row in m] for m in rho]
    built = su2().semidirect(rho_exact)
    assert np.array_equal(built.f, se3().f)


def test_direct_sum_commutes():
    s = su2().direct_sum(heisenberg(1))
    assert s.dim == 6 and np.all(s.f[:3, 3:, :] == 0) and np.all(s.f[3:, :3, :] == 0)
    assert not s.is_semisimple()


def _jacobi_breaking_constants():
    """Bianchi-like constants with n1 = a = 1: [e0,e1] = e1, [e1,e2] = e0, [e2,e0] = -e2.

    In 3 dimensions Jacobi holds iff N a = 0 (Ellis-MacCallum); here N a = (1,0,0):
    [e0,[e1,e2]] + [e1,[e2,e0]] + [e2,[e0,e1]] = 0 - e0 - e0 = -2 e0.
    """
    f = np.zeros((3, 3, 3), dtype=object)
    f[:, :, :] = 0
    for m, a, b, v in ((1, 0, 1, 1), (0, 1, 2, 1), (2, 2, 0, -1)):
        f[m, a, b], f[m, b, a] = v, -v
    return f


def test_broken_jacobi_is_rejected_with_residual():
    """Negative control: constants with N a != 0 break Jacobi by 2; the error reports that residual."""
    bad = _jacobi_breaking_constants()
    with pytest.raises(ValueError, match=r"Jacobi identity exactly: worst residual 2 at"):
        LieAlgebra.from_structure_constants(bad, name="broken")
    with pytest.raises(ValueError, match=r"Jacobi identity: worst residual 2 at .*tolerance"):
        LieAlgebra.from_structure_constants(np.array(bad, dtype=float), name="broken-float")


def test_non_antisymmetric_constants_rejected():
    f = np.zeros((2, 2, 2))
    f[1, 0, 1] = 1.0
    with pytest.raises(ValueError, match="not antisymmetric"):
        LieAlgebra.from_structure_constants(f)


def test_bianchi_parameters_validated():
    with pytest.raises(ValueError, match="h < 0"):
        bianchi("VI_h", 1)
    with pytest.raises(ValueError, match="h > 0"):
        bianchi("VII_h", -1)
    with pytest.raises(ValueError, match="unknown Bianchi type"):
        bianchi("X")
    assert abelian(4).dim == 4 and heisenberg(3).dim == 7


@pytest.mark.parametrize("kind", ["III", "IV", "V", "VI_h", "VII_h"])
def test_bianchi_class_B_not_unimodular(kind):
    """Class B (a != 0) algebras have tr ad != 0; class A ones are unimodular."""
    alg = bianchi(kind, {"VI_h": -2, "VII_h": "1/9"}.get(kind))
    assert not alg.is_unimodular()
    for a_kind in ("I", "II", "VI0", "VII0", "VIII", "IX"):
        assert bianchi(a_kind).is_unimodular()
