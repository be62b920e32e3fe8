"""Direct checks of the paper's printed formulas, each from first principles (no code under test as judge).

Every function returns an :class:`Outcome` (``ok``, ``error``, ``tolerance``, ``detail``).
A check named ``..._printed`` evaluates the paper's formula *as printed*; where the paper
is wrong (an erratum) that check is expected to fail and a ``..._corrected`` check
states the corrected formula and must pass. The claims registry (oracles.claims)
records which is which.

Tools of the first-principles route:

* su(2) group elements as 2x2 matrices ``exp(x^a E_a)``, ``E_a = -(i/2) sigma_a``
  (docs/conventions.md), coordinates of the first kind recovered by ``mpmath.logm``
  (``x^a = -2 tr(X E_a)`` since ``tr(E_a E_b) = -delta_ab / 2``), derivatives by
  ``mpmath.diff``; all at 30+ digits, tolerance ``10^-(dps - 8)`` times the scale;
* exact rational arithmetic (sympy) for algebraic identities.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import mpmath
import sympy as sp

__all__ = ["PAPER_CHECKS", "Outcome", "paper_labels", "paper_path", "run_paper_check"]

DPS = 30


@dataclass
class Outcome:
    """``ok``: the claim as stated holds; ``error``/``tolerance``: the measured defect and its bound."""

    ok: bool
    error: float | None = None
    tolerance: float | None = None
    detail: str = ""


def _tol(scale=1) -> mpmath.mpf:
    # error model for the mpmath first-principles route: mpmath.diff at DPS + 15 guard digits
    # is good to ~DPS digits; we ask for DPS - 8 correct digits of the scale.
    return mpmath.mpf(10) ** (-(DPS - 8)) * max(mpmath.mpf(1), abs(scale))


# ------------------------------------------------------------------ su(2) group model
def _E():
    s = [
        mpmath.matrix([[0, 1], [1, 0]]),
        mpmath.matrix([[0, -1j], [1j, 0]]),
        mpmath.matrix([[1, 0], [0, -1]]),
    ]
    return [s_ * mpmath.mpc(0, -0.5) for s_ in s]


def _g(x):
    E = _E()
    return mpmath.expm(sum((x[a] * E[a] for a in range(3)), mpmath.zeros(2, 2)))


def _coords(G):
    E = _E()
    X = mpmath.logm(G)
    return [
        mpmath.re(-2 * sum(X[i, j] * E[a][j, i] for i in range(2) for j in range(2)))
        for a in range(3)
    ]


def _eps(a, b, c) -> int:
    return ((a - b) * (b - c) * (c - a)) // 2


def _ad(x):
    return mpmath.matrix(
        [[sum(x[a] * _eps(m, a, b) for a in range(3)) for b in range(3)] for m in range(3)]
    )


# Independent of refimpl/_phi.py on purpose: these checks judge refimpl from first principles.
def _phi1(M, terms=80):
    out, term = mpmath.eye(M.rows), mpmath.eye(M.rows)
    for k in range(1, terms):
        term = term * M / (k + 1)
        out += term
    return out


_X0 = ("0.4", "-0.7", "0.9")


def _jac(fn, x, n=3):
    """``J[i][b] = d fn(x)_i / d x_b`` by mpmath.diff."""
    cols = []
    for b in range(n):
        cols.append(
            [
                mpmath.diff(
                    lambda s, i=i, b=b: fn([x[k] + (s if k == b else 0) for k in range(n)])[i], 0
                )
                for i in range(len(fn(x)))
            ]
        )
    return mpmath.matrix([[cols[b][i] for b in range(n)] for i in range(len(cols[0]))])


def _maxabs(M):
    return max(
        abs(v)
        for v in (
            M if isinstance(M, list) else [M[i, j] for i in range(M.rows) for j in range(M.cols)]
        )
    )


# ---------------------------------------------------------------- twee1: L(g, h)
def twee1_frame_printed() -> Outcome:
    """Printed: ``L^a_b(g, h) = d(gh)^a / dg^b``, so ``e^L_b = L^m_b(g, e) d/dg^m`` would be
    ``d/dg^b`` (the derivative of ``g e`` in ``g`` is the identity). The left-invariant field is
    ``d/ds g exp(s e_b)``; compare."""
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in _X0]
        true = _jac(lambda s: _coords(_g(x) * _g(s)), [mpmath.mpf(0)] * 3)  # d/ds x(g exp(s e_b))
        printed = _jac(lambda y: _coords(_g(y) * _g([0, 0, 0])), x)  # d(g h)/dg at h = e
        err = _maxabs(printed - true)
    return Outcome(
        bool(err <= _tol()), float(err), float(_tol()), "d(gh)/dg at h=e vs d/ds g exp(s e_b)"
    )


def twee1_frame_corrected() -> Outcome:
    """Corrected: ``L^a_b(g, h) = d(gh)^a / dh^b``; then ``L(g, e) = phi1(-ad_x)^-1`` (docs/conventions.md)
    and ``L(g^-1, g) = phi1(-ad_x)`` (twee1, twee4, twee5: the coframe is dual to the frame)."""
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in _X0]
        dh = _jac(lambda y: _coords(_g(x) * _g(y)), [mpmath.mpf(0)] * 3)  # d(gh)/dh at h = e
        xm = [-v for v in x]
        dh_co = _jac(lambda y: _coords(_g(xm) * _g(y)), x)  # d(g^-1 h)/dh at h = g
        A = _phi1(-_ad(x))
        err = max(
            _maxabs(dh - mpmath.inverse(A)), _maxabs(dh_co - A), _maxabs(dh_co * dh - mpmath.eye(3))
        )
    return Outcome(
        bool(err <= _tol()),
        float(err),
        float(_tol()),
        "L(g,e) = phi1(-ad_x)^-1, L(g^-1,g) = phi1(-ad_x)",
    )


def twee3_coadjoint() -> Outcome:
    """``pi^R = Ad(g^-1)^T pi^L`` with ``pi^L_m = p_n L^n_m(g, e)``, ``pi^R_m = p_n R^n_m(g, e)``,
    ``R(g, e) = d(hg)/dh`` at ``h = e`` (right-invariant frame)."""
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in _X0]
        p = mpmath.matrix(["0.3", "-1.1", "0.8"])
        L = _jac(lambda y: _coords(_g(x) * _g(y)), [mpmath.mpf(0)] * 3)
        R = _jac(lambda y: _coords(_g(y) * _g(x)), [mpmath.mpf(0)] * 3)
        piL, piR = L.T * p, R.T * p
        Ad_inv = mpmath.expm(-_ad(x))
        err = _maxabs(piR - Ad_inv.T * piL)
    return Outcome(bool(err <= _tol()), float(err), float(_tol()), "pi^R vs Ad(g^-1)^T pi^L")


# ---------------------------------------------------------------- gravity: twee15 -- twee17
_LVEC, _GAMMA = ("0.2", "-0.5", "1.1"), ("0.6", "0.3", "-0.9")


def twee16_gravity_gradient() -> Outcome:
    """``<dV|e^L_mu> = -(Gamma | ad(e_mu) L)``, ``Gamma = Ad(g)^T gamma``, for ``V = -(gamma | Ad(g) L)``."""
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in _X0]
        L, gam = mpmath.matrix(list(_LVEC)), mpmath.matrix(list(_GAMMA))
        Ad = mpmath.expm(_ad(x))

        def V(s, mu):
            e = [mpmath.mpf(0)] * 3
            e[mu] = s
            return -(gam.T * (Ad * mpmath.expm(_ad(e))) * L)[0]

        lhs = [mpmath.diff(lambda s, mu=mu: V(s, mu), 0) for mu in range(3)]
        Gam = Ad.T * gam
        rhs = [
            -sum(Gam[a] * _eps(a, mu, b) * L[b] for a in range(3) for b in range(3))
            for mu in range(3)
        ]
        err = max(abs(u - v) for u, v in zip(lhs, rhs))
    return Outcome(
        bool(err <= _tol()), float(err), float(_tol()), "derivative of V along g exp(s e_mu)"
    )


def _gamma_rate(Omega):
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in _X0]
        gam = mpmath.matrix(list(_GAMMA))
        Ad = mpmath.expm(_ad(x))
        dG = [
            mpmath.diff(
                lambda s, m=m: ((Ad * mpmath.expm(_ad([s * o for o in Omega]))).T * gam)[m], 0
            )
            for m in range(3)
        ]
        return dG, Ad.T * gam


_OMEGA = ("0.7", "0.2", "-0.4")


def _twee17(index, label: str) -> Outcome:
    """``dGamma_mu/dt`` along ``dg/dt = g Omega`` against ``sum_ab Gamma_a Omega^b eps(index(a, b, mu))``."""
    with mpmath.workdps(DPS + 15):
        Om = [mpmath.mpf(v) for v in _OMEGA]
        dG, G = _gamma_rate(Om)
        form = [
            sum(G[a] * Om[b] * _eps(*index(a, b, mu)) for a in range(3) for b in range(3))
            for mu in range(3)
        ]
        err = max(abs(u - v) for u, v in zip(dG, form))
        tol = _tol(max(abs(v) for v in dG))
    return Outcome(bool(err <= tol), float(err), float(tol), label)


def twee17_printed() -> Outcome:
    """Printed: ``dGamma_mu/dt = Gamma_a f^a_{mu b} Omega^b`` along ``dg/dt = g Omega``."""
    return _twee17(lambda a, b, mu: (a, mu, b), "printed sign")


def twee17_corrected() -> Outcome:
    """Corrected: ``dGamma_mu/dt = Omega^b f^a_{b mu} Gamma_a = (ad_Omega^T Gamma)_mu``
    (for so(3): ``dGamma/dt = Gamma x Omega``)."""
    return _twee17(lambda a, b, mu: (a, b, mu), "corrected sign")


def _ref_field(theta, ups, pot, x, pi, inertia=((2, 0, 0), (0, 3, 0), (0, 0, 5))):
    from tstarg.refimpl import su2
    from tstarg.refimpl.reference import Reference

    ref = Reference(DPS)
    return ref.hamiltonian_vector_field_mp(
        su2(), theta, ups, [list(r) for r in inertia], pot, x, pi
    )


def euler_equations_printed() -> Outcome:
    """twee12/twee14/twee18 (Theta = 0) and drie5/drie6/drie12 (Theta = -xi.f), as printed, against
    the reference vector field (vier10, vier11 with Upsilon = 0, Phi = Psi = 1) for su(2) with gravity:
    ``dpi_mu/dt = -dV_mu + Omega^a (pi_k f^k_{a mu} - Theta_{a mu})`` with
    ``-dV_mu = Gamma_a f^a_{mu b} L^b`` (twee18), and for drie12 ``dpi'/dt`` with ``pi' = pi + xi``."""
    xi = ["1/3", "-1/5", "2/7"]
    theta = [
        [
            sp.Rational(0) - sum(sp.Rational(xi[k]) * _eps(k, a, b) for k in range(3))
            for b in range(3)
        ]
        for a in range(3)
    ]
    zero = [[0] * 3 for _ in range(3)]
    pot = {"kind": "gravity", "L": list(_LVEC), "gamma": list(_GAMMA)}
    pi = ["0.5", "-0.3", "0.8"]
    worst, tol_w = mpmath.mpf(0), mpmath.mpf(0)
    with mpmath.workdps(DPS + 15):
        x = [mpmath.mpf(v) for v in _X0]
        Gam = mpmath.expm(_ad(x)).T * mpmath.matrix(list(_GAMMA))
        L = mpmath.matrix(list(_LVEC))
        Iinv = [mpmath.mpf(1) / 2, mpmath.mpf(1) / 3, mpmath.mpf(1) / 5]
        piv = [mpmath.mpf(v) for v in pi]
        Om = [Iinv[a] * piv[a] for a in range(3)]
        for th, xs in (
            (zero, [0, 0, 0]),
            (theta, [mpmath.mpf(sp.Rational(v).p) / sp.Rational(v).q for v in xi]),
        ):
            xd, pd = _ref_field(th, zero, pot, list(_X0), pi)
            thm = [
                [mpmath.mpf(sp.Rational(th[a][b]).p) / sp.Rational(th[a][b]).q for b in range(3)]
                for a in range(3)
            ]
            # twee18 / drie6 form
            pr = [
                -sum(piv[a] * _eps(a, mu, b) * Om[b] for a in range(3) for b in range(3))
                + sum(Gam[a] * _eps(a, mu, b) * L[b] for a in range(3) for b in range(3))
                - sum(Om[a] * thm[a][mu] for a in range(3))
                for mu in range(3)
            ]
            # drie12 form in pi' (same time derivative since xi is constant)
            pp = [piv[k] + xs[k] for k in range(3)]
            pr12 = [
                sum(Gam[a] * _eps(a, mu, b) * L[b] for a in range(3) for b in range(3))
                + sum(Om[a] * pp[k] * _eps(k, a, mu) for a in range(3) for k in range(3))
                for mu in range(3)
            ]
            # drie4 / twee13: Omega = L(g^-1, g) xdot = phi1(-ad_x) xdot
            Om_ref = _phi1(-_ad(x)) * xd
            scale = max(abs(v) for v in pd)
            err = max(
                [abs(pd[m] - pr[m]) for m in range(3)]
                + [abs(pd[m] - pr12[m]) for m in range(3)]
                + [abs(Om_ref[m] - Om[m]) for m in range(3)]
            )
            worst = max(worst, err)
            tol_w = max(tol_w, _tol(scale))
    return Outcome(
        bool(worst <= tol_w),
        float(worst),
        float(tol_w),
        "twee13/14/18, drie4/5/6/11/12 vs reference",
    )


# ---------------------------------------------------------------- Liouville forms and Darboux
def liouville_forms() -> Outcome:
    """twee6, drie1, drie7, drie8: ``-d(pi'_m eps_L^m)`` in holonomic coordinates ``(x, pi)`` equals
    ``B^T W B`` with ``B = diag(phi1(-ad_x), 1)``, ``W = [[pi'.f, 1], [-1, 0]]`` (``pi' = pi + xi``;
    ``xi = 0`` is twee6). The matrix of ``-d theta`` is ``Omega_ij = d_j theta_i - d_i theta_j``."""
    worst = mpmath.mpf(0)
    for xi_s in (("0", "0", "0"), ("0.3", "-0.2", "0.5")):
        with mpmath.workdps(DPS + 15):
            x = [mpmath.mpf(v) for v in _X0]
            pi = [mpmath.mpf(v) for v in ("0.5", "-0.3", "0.8")]
            xi = [mpmath.mpf(v) for v in xi_s]
            z0 = x + pi

            def theta(z, xi=xi):
                A = _phi1(-_ad(z[:3]))
                pp = mpmath.matrix([z[3 + k] + xi[k] for k in range(3)])
                return list(A.T * pp) + [mpmath.mpf(0)] * 3

            J = _jac(theta, z0, n=6)  # J[i, j] = d theta_i / d z_j
            Om = J - J.T
            A = _phi1(-_ad(x))
            B = mpmath.zeros(6, 6)
            for i in range(3):
                for j in range(3):
                    B[i, j] = A[i, j]
                B[3 + i, 3 + i] = 1
            W = mpmath.zeros(6, 6)
            for a in range(3):
                for b in range(3):
                    W[a, b] = sum((pi[k] + xi[k]) * _eps(k, a, b) for k in range(3))
                W[a, 3 + a], W[3 + a, a] = 1, -1
            worst = max(worst, _maxabs(Om - B.T * W * B))
    return Outcome(
        bool(worst <= _tol()), float(worst), float(_tol()), "-d theta vs the frame matrix"
    )


def drie9_darboux() -> Outcome:
    """drie9: ``(g^a, p'_mu = p_mu + xi_b L^b_mu(g^-1, g))`` are Darboux coordinates of ``omega_I``:
    the reference Poisson tensor (Theta = -xi.f, Upsilon = 0) pushed to ``(x, p')`` is ``[[0, 1], [-1, 0]]``.
    ``p = phi1(-ad_x)^T pi`` (since ``pi_m = p_n L^n_m(g, e)``)."""
    from tstarg.refimpl import su2
    from tstarg.refimpl.reference import Reference

    xi_s = ("1/3", "-1/5", "2/7")
    theta = [
        [-sum(sp.Rational(xi_s[k]) * _eps(k, a, b) for k in range(3)) for b in range(3)]
        for a in range(3)
    ]
    pi_s = ("0.5", "-0.3", "0.8")
    P = Reference(DPS + 10).poisson_tensor_mp(
        su2(), theta, [[0] * 3 for _ in range(3)], list(_X0), list(pi_s)
    )
    with mpmath.workdps(DPS + 15):
        xi = [mpmath.mpf(sp.Rational(v).p) / sp.Rational(v).q for v in xi_s]
        z0 = [mpmath.mpf(v) for v in _X0 + pi_s]

        def newc(z):
            A = _phi1(-_ad(z[:3]))
            pp = mpmath.matrix([z[3 + k] + xi[k] for k in range(3)])
            return list(z[:3]) + list(A.T * pp)

        J = _jac(newc, z0, n=6)
        Pn = J * P * J.T
        can = mpmath.zeros(6, 6)
        for i in range(3):
            can[i, 3 + i], can[3 + i, i] = 1, -1
        err = _maxabs(Pn - can)
    return Outcome(
        bool(err <= _tol()), float(err), float(_tol()), "pushed Poisson tensor vs canonical"
    )


# ---------------------------------------------------------------- een1 -- een3
def een3_transformation() -> Outcome:
    """een3 (exact): under ``x' = A x + a``, ``p' = p A^-1`` (een2), ``omega_0 + omega_F + omega_B`` keeps its
    form with ``F' = A^-T F A^-1``, ``B' = A B A^T`` (constant F, B): ``M^T Omega(F', B') M = Omega(F, B)``
    with ``M = diag(A, A^-T)`` the Jacobian on ``(x, p)`` columns."""
    A = sp.Matrix([[2, 1, 0], [sp.Rational(1, 3), -1, 4], [0, 5, sp.Rational(-1, 2)]])
    F = sp.Matrix([[0, 3, -1], [-3, 0, sp.Rational(2, 7)], [1, sp.Rational(-2, 7), 0]])
    B = sp.Matrix([[0, sp.Rational(1, 5), 2], [sp.Rational(-1, 5), 0, -3], [-2, 3, 0]])

    def Om(F_, B_):
        return sp.BlockMatrix([[F_, sp.eye(3)], [-sp.eye(3), B_]]).as_explicit()

    Ai = A.inv()
    M = sp.diag(A, Ai.T)
    Fp = Ai.T * F * Ai  # F'_ij = F_kl (A^-1)^k_i (A^-1)^l_j
    Bp = A * B * A.T  # B'^kl = A^k_i A^l_j B^ij
    diff = sp.simplify(M.T * Om(Fp, Bp) * M - Om(F, B))
    ok = diff == sp.zeros(6, 6)
    return Outcome(
        bool(ok), 0.0 if ok else float(max(abs(v) for v in diff)), 0.0, "exact rationals"
    )


def _free_indices(term: str) -> set:
    idx = re.findall(r"[\^_]\{?([a-z])\}?", term)
    return {i for i in idx if idx.count(i) == 1}


EEN2_PRINTED = ("x'^i", ["A^i_j x^j", "a^k"])
EEN2_CORRECTED = ("x'^i", ["A^i_j x^j", "a^i"])


def een2_printed() -> Outcome:
    """een2 as printed, ``x'^i = A^i_j x^j + a^k``: every term must carry the free index ``i``."""
    lhs, terms = EEN2_PRINTED
    bad = [t for t in terms if _free_indices(t) != _free_indices(lhs)]
    return Outcome(not bad, None, None, f"terms with the wrong free index: {bad}")


def een2_corrected() -> Outcome:
    """een2 corrected, ``x'^i = A^i_j x^j + a^i``."""
    lhs, terms = EEN2_CORRECTED
    bad = [t for t in terms if _free_indices(t) != _free_indices(lhs)]
    return Outcome(not bad, None, None, f"terms with the wrong free index: {bad}")


# ---------------------------------------------------------------- labels
# The equation labels of paper.tex in order of appearance, as printed (drie5 twice); used when the
# source is not at hand. tests/test_claims.py checks this copy against the file when it is.
PAPER_LABELS = (
    "een1",
    "een2",
    "een3",
    "twee1",
    "twee2",
    "twee3",
    "twee4",
    "twee5",
    "twee6",
    "twee7",
    "twee8",
    "twee9",
    "twee10",
    "twee11",
    "twee12",
    "twee13",
    "twee14",
    "twee15",
    "twee16",
    "twee17",
    "twee18",
    "drie1",
    "drie2",
    "drie3",
    "drie4",
    "drie5",
    "drie6",
    "drie7",
    "drie8",
    "drie9",
    "drie10",
    "drie11",
    "drie5",
    "vier1",
    "vier2",
    "vier3",
    "vier4",
    "vier5",
    "vier6",
    "vier7",
    "vier8",
    "vier9",
    "vier10",
    "vier11",
    "vier12",
    "vier13",
    "vier14",
    "vijf1",
    "vijf2",
    "vijf3",
    "vijf4",
    "vijf5",
    "vijf6",
    "vijf7",
    "vijf8",
    "vijf9",
    "vijf10",
    "vijf11",
    "vijf12",
    "vijf13",
    "vijf14",
    "vijf15",
    "vijf16",
    "zeven1",
    "zeven2",
    "zeven3",
)


def paper_path() -> Path | None:
    """The paper's LaTeX source, needed only to re-index the paper (the index ships with the
    package, :mod:`oracles.paper_index`): ``$TSTARG_PAPER``, else a ``shared/paper.tex`` in a
    folder above the checkout (the authors' layout), else None."""
    repo = Path(__file__).resolve().parents[1]
    cands = [os.environ.get("TSTARG_PAPER")] + [a / "shared" / "paper.tex" for a in repo.parents]
    for c in cands:
        if c and Path(c).is_file():
            return Path(c)
    return None


def paper_labels(text: str | None = None) -> list[str]:
    """Equation labels in order of appearance (section labels excluded: un, deux, ..., sept); from
    ``text``, else the paper's file (:func:`paper_path`), else the embedded :data:`PAPER_LABELS`."""
    if text is None:
        p = paper_path()
        if p is None:
            return list(PAPER_LABELS)
        text = p.read_text()
    labels = re.findall(r"\\label\{([a-z]+[0-9]+)\}", text)
    return labels


def labels_unique_printed() -> Outcome:
    """The paper's equation labels are unique, as printed."""
    labels = paper_labels()
    dup = sorted({x for x in labels if labels.count(x) > 1})
    return Outcome(not dup, None, None, f"duplicated labels: {dup}")


def labels_unique_corrected() -> Outcome:
    """With the second ``drie5`` (the dpi'/dt equation after drie11) renamed ``drie12``, labels are unique."""
    labels = paper_labels()
    seen, fixed = set(), []
    for lab in labels:
        fixed.append("drie12" if lab == "drie5" and lab in seen else lab)
        seen.add(lab)
    dup = sorted({x for x in fixed if fixed.count(x) > 1})
    i11 = fixed.index("drie11")
    return Outcome(
        not dup and fixed[i11 + 1] == "drie12", None, None, f"duplicated after renaming: {dup}"
    )


# ---------------------------------------------------------------- section quatre identities (exact)
def _random_model(name: str, seed: int):
    import random

    from tstarg.refimpl import catalogue, cocycle_basis

    rnd = random.Random(seed)
    alg = catalogue(name)
    n = alg.dim
    F = alg.f_exact
    basis = cocycle_basis(alg, exact=True)
    Th = sp.zeros(n, n)
    for B_ in basis:
        Th += sp.Rational(rnd.randint(-5, 5), rnd.randint(1, 4)) * sp.Matrix(B_)
    U = sp.zeros(n, n)
    for i in range(n):
        for j in range(i + 1, n):
            v = sp.Rational(rnd.randint(-3, 3), rnd.randint(1, 3))
            U[i, j], U[j, i] = v, -v
    return alg, F, Th, U


def quatre_identities(name: str = "su(2)", seed: int = 0) -> Outcome:
    """vier3 -- vier9 exactly (rationals) for one catalogue algebra, random cocycle Theta, Upsilon, pi:
    ``Psi = Phi^T``; ``Phi S = S Psi`` and ``U Phi = Psi U`` antisymmetric (vier6); ``det Phi = det Psi`` (vier7);
    ``U Phi^-1 = Psi^-1 U`` and ``Phi^-1 S = S Psi^-1`` antisymmetric (after vier7); the vector field of
    vier8 (both printed forms) solves ``X^T W = dA^T`` (vier4, vier5); ``-W^-1`` has the blocks of vier9."""
    import random

    alg, F, Th, U = _random_model(name, seed)
    n = alg.dim
    rnd = random.Random(seed + 1)
    pi = [sp.Rational(rnd.randint(-6, 6), rnd.randint(1, 5)) for _ in range(n)]
    S = sp.Matrix(n, n, lambda a, b: sum(pi[m] * F[m, a, b] for m in range(n))) - Th
    Phi, Psi = sp.eye(n) + S * U, sp.eye(n) + U * S
    if Phi.det() == 0:
        return Outcome(True, None, None, "degenerate draw: skipped")
    Pi_, Si_ = Phi.inv(), Psi.inv()
    checks = {
        "Psi=Phi^T": Psi - Phi.T,
        "PhiS=SPsi": Phi * S - S * Psi,
        "PhiS antisym": Phi * S + (Phi * S).T,
        "UPhi=PsiU": U * Phi - Psi * U,
        "UPhi antisym": U * Phi + (U * Phi).T,
        "UPhi^-1=Psi^-1U": U * Pi_ - Si_ * U,
        "Phi^-1S=SPsi^-1": Pi_ * S - S * Si_,
        "Phi^-1S antisym": Pi_ * S + (Pi_ * S).T,
        "UPhi^-1 antisym": U * Pi_ + (U * Pi_).T,
    }
    dA = sp.Matrix([sp.Rational(rnd.randint(-6, 6), rnd.randint(1, 5)) for _ in range(2 * n)])
    dl, du = dA[:n, 0], dA[n:, 0]  # <dA|e^L_a>, dA/dpi_m
    W = sp.BlockMatrix([[S, sp.eye(n)], [-sp.eye(n), U]]).as_explicit()
    Xu1 = Si_ * (du - U * dl)
    Xu2 = ((du.T + dl.T * U) * Pi_).T
    Xd1 = Pi_ * (-dl - S * du)
    Xd2 = ((-dl.T + du.T * S) * Si_).T
    X = sp.Matrix.vstack(Xu1, Xd1)
    checks["vier8 forms"] = sp.Matrix.vstack(Xu1 - Xu2, Xd1 - Xd2)
    checks["vier5"] = sp.Matrix.vstack(
        (Xu1.T * Phi - (du.T + dl.T * U)).T, (Xd1.T * Psi - (-dl.T + du.T * S)).T
    )
    checks["vier4"] = (X.T * W).T - dA
    Wi = -W.inv()
    blocks = sp.BlockMatrix([[-U * Pi_, Si_], [-Pi_, -S * Si_]]).as_explicit()
    checks["vier9"] = Wi - blocks
    checks["vier7"] = sp.Matrix([Phi.det() - Psi.det()])
    bad = [k for k, M in checks.items() if any(sp.simplify(v) != 0 for v in M)]
    return Outcome(
        not bad, 0.0 if not bad else None, 0.0, f"{name}: failed {bad}" if bad else f"{name}: exact"
    )


def vier12_degree(name: str = "su(2)", seed: int = 0) -> Outcome:
    """vier12: ``Delta(pi)`` is a polynomial in ``pi`` of degree at most ``N = dim g``."""
    alg, F, Th, U = _random_model(name, seed)
    n = alg.dim
    pi = sp.symbols(f"p0:{n}")
    S = sp.Matrix(n, n, lambda a, b: sum(pi[m] * F[m, a, b] for m in range(n))) - Th
    D = sp.expand((sp.eye(n) + S * U).det())
    deg = sp.Poly(D, *pi).total_degree() if D.free_symbols else 0
    return Outcome(deg <= n, None, None, f"{name}: degree {deg} <= {n}")


def zeven1_jacobi(name: str = "su(2)") -> Outcome:
    """zeven1 as printed is exactly the condition for the bracket drie3
    ``{pi_a, pi_b} = -(pi_k f^k_ab - Theta_ab)`` to satisfy Jacobi (equivalently, for
    ``Theta_L`` to be closed): both give the same linear space of antisymmetric ``Theta``."""
    from tstarg.refimpl import catalogue

    alg = catalogue(name)
    n = alg.dim
    F = alg.f_exact
    t = {}
    Th = sp.zeros(n, n)
    for a in range(n):
        for b in range(a + 1, n):
            t[(a, b)] = sp.Symbol(f"t{a}_{b}")
            Th[a, b], Th[b, a] = t[(a, b)], -t[(a, b)]
    pi = sp.symbols(f"p0:{n}")
    P = sp.Matrix(n, n, lambda a, b: -(sum(pi[k] * F[k, a, b] for k in range(n)) - Th[a, b]))
    jac = []
    for a in range(n):
        for b in range(n):
            for c in range(n):
                e = sum(
                    P[a, l] * sp.diff(P[b, c], pi[l])
                    + P[b, l] * sp.diff(P[c, a], pi[l])
                    + P[c, l] * sp.diff(P[a, b], pi[l])
                    for l in range(n)
                )
                jac.append(sp.expand(e))
    # Jacobi must hold for all pi: every coefficient in pi
    jac_eqs = []
    for e in jac:
        jac_eqs.extend(sp.Poly(e, *pi).coeffs() if e != 0 else [])
    z1 = [
        sp.expand(
            -sum(Th[k, g] * F[k, a, b] for k in range(n))
            + sum(Th[k, b] * F[k, a, g] for k in range(n))
            - sum(Th[k, a] * F[k, b, g] for k in range(n))
        )
        for a in range(n)
        for b in range(n)
        for g in range(n)
    ]
    syms = list(t.values())

    def space(eqs):
        eqs = [e for e in eqs if e != 0]
        if not eqs:
            return sp.zeros(0, len(syms))
        M = sp.Matrix([[sp.diff(e, s) for s in syms] for e in eqs])
        return M.rref()[0]

    R1, R2 = space(jac_eqs), space(z1)
    r1 = R1.rank()
    ok = r1 == R2.rank() and sp.Matrix.vstack(R1, R2).rank() == r1
    return Outcome(
        bool(ok), None, None, f"{name}: rank of conditions {r1}, dim Z^2 = {len(syms) - r1}"
    )


def zeven3_whitehead(name: str = "su(2)") -> Outcome:
    """zeven3 and the Whitehead lemma: ``Theta = -xi.f`` is a cocycle for every ``xi`` (symbolic), and for a
    semisimple algebra every cocycle is of this form (``dim Z^2 = dim B^2``)."""
    from tstarg.refimpl import catalogue, cohomology

    alg = catalogue(name)
    n = alg.dim
    F = alg.f_exact
    xi = sp.symbols(f"x0:{n}")
    Th = sp.Matrix(n, n, lambda a, b: -sum(xi[m] * F[m, a, b] for m in range(n)))
    z1 = [
        sp.expand(
            -sum(Th[k, g] * F[k, a, b] for k in range(n))
            + sum(Th[k, b] * F[k, a, g] for k in range(n))
            - sum(Th[k, a] * F[k, b, g] for k in range(n))
        )
        for a in range(n)
        for b in range(n)
        for g in range(n)
    ]
    cob = all(e == 0 for e in z1)
    coh = cohomology(alg, exact=True)
    semisimple = alg.is_semisimple()
    ok = cob and (not semisimple or coh.dim_h2 == 0)
    return Outcome(
        bool(ok),
        None,
        None,
        f"{name}: -xi.f cocycle: {cob}; semisimple: {semisimple}; dim H^2 = {coh.dim_h2}",
    )


def vier2_closed() -> Outcome:
    """vier2 (closedness of omega_L, i.e. Jacobi for its Poisson tensor) for su(2) with Theta and Upsilon:
    the Jacobiator of the reference's holonomic ``P`` (derivatives by central differences at 45 digits,
    step 1e-15, truncation ~1e-30) vanishes."""
    from tstarg.refimpl import su2
    from tstarg.refimpl.reference import Reference

    theta = [
        [
            -sum(sp.Rational(v) * _eps(k, a, b) for k, v in enumerate(("1/3", "-1/5", "2/7")))
            for b in range(3)
        ]
        for a in range(3)
    ]
    ups = [
        [
            sum(sp.Rational(v) * _eps(l, m, k) for l, v in enumerate(("1/4", "1/6", "-1/3")))
            for k in range(3)
        ]
        for m in range(3)
    ]
    ref = Reference(45)
    z0 = [mpmath.mpf(v) for v in _X0 + ("0.5", "-0.3", "0.8")]
    with mpmath.workdps(60):
        h = mpmath.mpf(10) ** -15

        def P(z):
            return ref.poisson_tensor_mp(
                su2(), theta, ups, [str(v) for v in z[:3]], [str(v) for v in z[3:]]
            )

        P0 = P(z0)
        dP = []
        for l in range(6):
            zp = [v + (h if k == l else 0) for k, v in enumerate(z0)]
            zm = [v - (h if k == l else 0) for k, v in enumerate(z0)]
            dP.append((P(zp) - P(zm)) / (2 * h))
        worst = mpmath.mpf(0)
        for i in range(6):
            for j in range(6):
                for k in range(6):
                    e = sum(
                        P0[i, l] * dP[l][j, k] + P0[j, l] * dP[l][k, i] + P0[k, l] * dP[l][i, j]
                        for l in range(6)
                    )
                    worst = max(worst, abs(e))
        scale = _maxabs(P0) ** 2
        tol = mpmath.mpf(10) ** -20 * max(1, scale)
    return Outcome(bool(worst <= tol), float(worst), float(tol), "Jacobiator of P")


def cinq_nondegenerate() -> Outcome:
    from .su2_symbolic import residuals_nondegenerate

    r = residuals_nondegenerate()
    bad = [k for k, v in r.items() if not v]
    return Outcome(not bad, None, None, f"failed: {bad}" if bad else "all symbolic identities hold")


def cinq_degenerate() -> Outcome:
    from .su2_symbolic import residuals_degenerate

    r = residuals_degenerate()
    bad = [k for k, v in r.items() if not v]
    return Outcome(not bad, None, None, f"failed: {bad}" if bad else "all symbolic identities hold")


def cinq_gnh() -> Outcome:
    """vijf16 and the GNH outcome: refimpl.gnh on the paper's SU(2) model reproduces M_1 (C1), the
    secondary set (C21 = C22 = 0 on the final manifold), and a tangent solution of the form vijf15."""
    from .gnh_examples import EXAMPLES, check_example

    bad = [k for k in EXAMPLES if not EXAMPLES[k].get("slow") and not check_example(k)[0]]
    return Outcome(
        not bad, None, None, f"failed: {bad}" if bad else "worked examples reproduce their outcomes"
    )


def euler_equations_general(
    names=("sl(2,R)", "Bianchi III", "h(3)", "se(3)"), seed: int = 1
) -> Outcome:
    """twee12/twee14/twee18 and drie5/drie6 for other algebras (f from the catalogue, a random rational
    cocycle Theta, Upsilon = 0, gravity): the printed right-hand side
    ``dpi_m/dt = -pi_a f^a_mb Omega^b + Gamma_a f^a_mb L^b - Omega^a Theta_am`` (twee18 with drie6)
    and ``Omega = phi1(-ad_x) xdot = I^-1 pi`` (twee13, drie4) against the reference vector field."""
    import random

    from tstarg.refimpl.reference import Reference

    worst, tol_w, det = mpmath.mpf(0), mpmath.mpf(0), []
    for name in names:
        alg, F, Th, _U = _random_model(name, seed)
        n = alg.dim
        rnd = random.Random(seed + 2)
        xs = [sp.Rational(rnd.randint(-9, 9), 10) for _ in range(n)]
        ps = [sp.Rational(rnd.randint(-9, 9), 10) for _ in range(n)]
        Ls = [sp.Rational(rnd.randint(-9, 9), 10) for _ in range(n)]
        gs = [sp.Rational(rnd.randint(-9, 9), 10) for _ in range(n)]
        Id = [k + 1 for k in range(n)]
        inertia = [[Id[i] if i == j else 0 for j in range(n)] for i in range(n)]
        zero = [[0] * n for _ in range(n)]
        pot = {"kind": "gravity", "L": [str(v) for v in Ls], "gamma": [str(v) for v in gs]}
        xd, pd = Reference(DPS).hamiltonian_vector_field_mp(
            alg, Th.tolist(), zero, inertia, pot, [str(v) for v in xs], [str(v) for v in ps]
        )
        with mpmath.workdps(DPS + 15):

            def mp(v):
                return mpmath.mpf(sp.Rational(v).p) / sp.Rational(v).q

            Fm = [[[mp(F[m, a, b]) for b in range(n)] for a in range(n)] for m in range(n)]
            x = [mp(v) for v in xs]
            pi = [mp(v) for v in ps]
            L = [mp(v) for v in Ls]
            ad = mpmath.matrix(
                [[sum(x[a] * Fm[m][a][b] for a in range(n)) for b in range(n)] for m in range(n)]
            )
            Gam = mpmath.expm(ad).T * mpmath.matrix([mp(v) for v in gs])
            Om = [pi[a] / Id[a] for a in range(n)]
            thm = [[mp(Th[a, b]) for b in range(n)] for a in range(n)]
            pr = [
                -sum(pi[a] * Fm[a][mu][b] * Om[b] for a in range(n) for b in range(n))
                + sum(Gam[a] * Fm[a][mu][b] * L[b] for a in range(n) for b in range(n))
                - sum(Om[a] * thm[a][mu] for a in range(n))
                for mu in range(n)
            ]
            Om_ref = _phi1(-ad) * xd
            scale = max([mpmath.mpf(1)] + [abs(v) for v in pd])
            err = max(
                [abs(pd[m] - pr[m]) for m in range(n)] + [abs(Om_ref[m] - Om[m]) for m in range(n)]
            )
            worst = max(worst, err / scale)
            tol_w = _tol()
            det.append(f"{name}: {float(err):.1e}")
    return Outcome(bool(worst <= tol_w), float(worst), float(tol_w), "; ".join(det))


PAPER_CHECKS = {
    "twee1_frame_printed": twee1_frame_printed,
    "twee1_frame_corrected": twee1_frame_corrected,
    "twee3_coadjoint": twee3_coadjoint,
    "twee16_gravity_gradient": twee16_gravity_gradient,
    "twee17_printed": twee17_printed,
    "twee17_corrected": twee17_corrected,
    "euler_equations": euler_equations_printed,
    "euler_equations_general": euler_equations_general,
    "liouville_forms": liouville_forms,
    "drie9_darboux": drie9_darboux,
    "een3_transformation": een3_transformation,
    "een2_printed": een2_printed,
    "een2_corrected": een2_corrected,
    "labels_unique_printed": labels_unique_printed,
    "labels_unique_corrected": labels_unique_corrected,
    "quatre_identities": quatre_identities,
    "vier12_degree": vier12_degree,
    "zeven1_jacobi": zeven1_jacobi,
    "zeven3_whitehead": zeven3_whitehead,
    "vier2_closed": vier2_closed,
    "cinq_nondegenerate": cinq_nondegenerate,
    "cinq_degenerate": cinq_degenerate,
    "cinq_gnh": cinq_gnh,
}


_CACHE: dict = {}


def run_paper_check(name: str, *, fresh: bool = False) -> Outcome:
    """Run one check by name; results are cached per process (the checks are deterministic)."""
    if name not in PAPER_CHECKS:
        raise ValueError(f"unknown paper check {name!r}; known: {sorted(PAPER_CHECKS)}")
    if fresh or name not in _CACHE:
        _CACHE[name] = PAPER_CHECKS[name]()
    return _CACHE[name]
