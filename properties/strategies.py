"""Hypothesis strategies for models and points (Hypothesis' own API style).

All strategies are shrinkable and draw their randomness from Hypothesis (no
global RNG). Exact draws use small rationals so the reference and sympy can
work exactly.

* :func:`catalogue_algebras` -- algebras of the catalogue;
* :func:`cocycles` -- random elements of ``Z^2`` (exact nullspace of delta_2);
* :func:`upsilons` -- antisymmetric ``(n, n)`` matrices;
* :func:`points` -- ``(x, pi)`` in a conditioning regime:
  ``"generic"``, ``"near_degenerate"`` (cond(Phi) in ``[1e2, 1e12]``),
  ``"large_momenta"``, ``"near_chart_boundary"``.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import strategies as st

from refimpl import CATALOGUE_NAMES, LieAlgebra, catalogue, cocycle_basis

__all__ = ["catalogue_algebras", "cocycles", "upsilons", "points", "rationals", "REGIMES", "phi_condition"]

REGIMES = ("generic", "near_degenerate", "large_momenta", "near_chart_boundary")


def rationals(*, max_numerator: int = 9, denominator: int = 8) -> st.SearchStrategy[Fraction]:
    """Small rationals ``k / denominator`` with ``|k| <= max_numerator``."""
    return st.integers(-max_numerator, max_numerator).map(lambda k: Fraction(k, denominator))


def catalogue_algebras(*, names=None, max_dim: int | None = None, semisimple: bool | None = None):
    """Algebras of the catalogue, optionally filtered by dimension or semisimplicity."""
    pool = []
    for name in names or CATALOGUE_NAMES:
        alg = catalogue(name)
        if max_dim is not None and alg.dim > max_dim:
            continue
        if semisimple is not None and alg.is_semisimple() != semisimple:
            continue
        pool.append(alg)
    if not pool:
        raise ValueError("catalogue_algebras: the filters leave no algebra")
    return st.sampled_from(pool)


@st.composite
def cocycles(draw, algebra: LieAlgebra, *, exact: bool = True, zero: bool | None = None):
    """A random 2-cocycle of ``algebra``: a rational combination of an exact basis of Z^2.

    ``exact=True`` returns an object array of exact numbers; ``False`` floats.
    ``zero=True`` forces Theta = 0, ``False`` forbids it.
    """
    basis = cocycle_basis(algebra, exact=algebra.is_exact)
    n = algebra.dim
    if zero is True or not basis:
        if zero is False and not basis:
            raise ValueError(f"{algebra.name} has no non-zero cocycle")
        t = np.zeros((n, n), dtype=object)
        t[:, :] = 0
        return t if exact else np.zeros((n, n))
    coefs = draw(st.lists(rationals(), min_size=len(basis), max_size=len(basis)).filter(
        lambda c: zero is not False or any(c)), label="cocycle coefficients")
    t = sum((c * b for c, b in zip(coefs, basis)), np.zeros((n, n), dtype=object))
    if exact:
        return t
    return np.array(t, dtype=float)


@st.composite
def upsilons(draw, n: int, *, exact: bool = True, zero: bool | None = None, scale: Fraction = Fraction(1, 2)):
    """A random antisymmetric ``(n, n)`` Upsilon with rational entries of size ``<= 9/8 * scale``."""
    u = np.zeros((n, n), dtype=object)
    u[:, :] = Fraction(0)
    if zero is True:
        return u if exact else np.zeros((n, n))
    vals = draw(st.lists(rationals(), min_size=n * (n - 1) // 2, max_size=n * (n - 1) // 2).filter(
        lambda v: zero is not False or any(v)), label="upsilon entries")
    k = 0
    for i in range(n):
        for j in range(i + 1, n):
            u[i, j] = vals[k] * scale
            u[j, i] = -u[i, j]
            k += 1
    return u if exact else np.array(u, dtype=float)


def phi_condition(f, theta, upsilon, pi) -> float:
    """2-norm condition number of ``Phi = 1 + S Upsilon`` in float64 (for regime checks)."""
    f = np.asarray(f, dtype=float)
    S = np.einsum("m,mab->ab", np.asarray(pi, dtype=float), f) - np.asarray(theta, dtype=float)
    Phi = np.eye(f.shape[0]) + S @ np.asarray(upsilon, dtype=float)
    return float(np.linalg.cond(Phi))


def _degenerate_roots(f, theta, upsilon, pi0, d):
    """Real ``t`` with ``det Phi(pi0 + t d) = 0``: ``Phi = Phi0 + t S(d) U``, a generalized eigenproblem."""
    n = f.shape[0]
    S0 = np.einsum("m,mab->ab", pi0, f) - theta
    S1 = np.einsum("m,mab->ab", d, f)
    Phi0 = np.eye(n) + S0 @ upsilon
    B = S1 @ upsilon
    try:
        lam = np.linalg.eigvals(np.linalg.solve(Phi0, B))
    except np.linalg.LinAlgError:
        return []
    roots = [-1.0 / complex(v).real for v in lam if abs(complex(v).imag) < 1e-12 * max(1, abs(v)) and abs(v) > 1e-12]
    return [r for r in roots if np.isfinite(r) and abs(r) < 1e6]


@st.composite
def points(draw, algebra: LieAlgebra, theta=None, upsilon=None, *, regime: str = "generic"):
    """A point ``(x, pi)`` (float64 arrays) in a conditioning ``regime`` (see the module docstring).

    ``near_degenerate`` needs ``theta`` and ``upsilon`` (float or exact) and
    approaches a real root of ``Delta`` along a random line; the regime is
    rejected (``assume``-style filtering) where Delta has no real root there.
    """
    if regime not in REGIMES:
        raise ValueError(f"regime must be one of {REGIMES}, got {regime!r}")
    n = algebra.dim
    unit = st.floats(-1, 1, allow_nan=False, allow_infinity=False)
    vec = st.lists(unit, min_size=n, max_size=n).map(np.array)
    x = draw(vec, label="x direction")
    pi = draw(vec, label="pi")
    if regime == "generic":
        return x * 0.8, pi * 2
    if regime == "large_momenta":
        mag = draw(st.sampled_from([1e2, 1e4, 1e6]), label="momentum magnitude")
        return x * 0.8, pi * mag
    if regime == "near_chart_boundary":
        # |ad_x| close to (but below) 2 pi for compact directions: scale x so
        # that ||ad_x||_F / 2pi = rho.
        rho = draw(st.sampled_from([0.6, 0.8, 0.9]), label="rho")
        adx = np.einsum("a,mab->mb", x, algebra.f)
        nrm = np.linalg.norm(adx)
        if nrm == 0:
            return x, pi
        return x * (rho * 2 * np.pi / nrm), pi
    # near_degenerate
    if theta is None or upsilon is None:
        raise ValueError("points(regime='near_degenerate') needs theta and upsilon")
    th = np.array(theta, dtype=float)
    up = np.array(upsilon, dtype=float)
    d = draw(vec, label="line direction")
    roots = _degenerate_roots(algebra.f, th, up, pi, d) if np.any(d) and np.any(up) else []
    if not roots:
        from hypothesis import reject

        reject()
    t0 = roots[int(draw(st.integers(0, len(roots) - 1), label="root"))]
    target = 10.0 ** draw(st.integers(2, 12), label="log10 cond target")
    # cond(Phi) ~ 1/|delta| near a simple root; nudge to hit the target.
    dn = float(np.linalg.norm(d))
    delta = 1.0 / target
    sign = draw(st.sampled_from([-1.0, 1.0]), label="side")
    return x * 0.8, pi + (t0 + sign * delta / dn) * d
