"""Checks of section sept (cohomology): delta_1 and delta_2 (erratum in delta_1's components), zeven1 as
Jacobi, Whitehead's lemma (zeven3) and the counterexamples showing the hypotheses are needed."""

from __future__ import annotations

import itertools

import sympy as sp

from tstarg.refimpl import catalogue, cohomology

from . import algebras
from .common import Outcome

R = sp.Rational


def _zeven1(F, Th, n: int) -> list:
    """zeven1 as printed, one expression per ``(a, b, g)``: ``-Theta_kg f^k_ab + Theta_kb f^k_ag -
    Theta_ka f^k_bg`` (zero for a cocycle)."""
    return [
        sp.expand(
            -sum(Th[k, g] * F[k, a, b] for k in range(n))
            + sum(Th[k, b] * F[k, a, g] for k in range(n))
            - sum(Th[k, a] * F[k, b, g] for k in range(n))
        )
        for a in range(n)
        for b in range(n)
        for g in range(n)
    ]


def zeven1_jacobi(name: str = "su(2)") -> Outcome:
    """zeven1 as printed is exactly the condition for the bracket drie3
    ``{pi_a, pi_b} = -(pi_k f^k_ab - Theta_ab)`` to satisfy Jacobi (equivalently, for
    ``Theta_L`` to be closed): both give the same linear space of antisymmetric ``Theta``."""
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
    z1 = _zeven1(F, Th, n)
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
    alg = catalogue(name)
    n = alg.dim
    F = alg.f_exact
    xi = sp.symbols(f"x0:{n}")
    Th = sp.Matrix(n, n, lambda a, b: -sum(xi[m] * F[m, a, b] for m in range(n)))
    z1 = _zeven1(F, Th, n)
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


def _jacobi_ok(F) -> bool:
    n = len(F)
    for a, b, c, m in itertools.product(range(n), repeat=4):
        e = sum(
            F[k][a][b] * F[m][k][c] + F[k][b][c] * F[m][k][a] + F[k][c][a] * F[m][k][b]
            for k in range(n)
        )
        if e != 0:
            return False
    return True


def _delta1_matrix(F) -> sp.Matrix:
    """``delta_1: g* -> Lambda^2 g*``, ``(delta_1 xi)(e_a, e_b) = -xi([e_a, e_b])``, rows ``a < b``."""
    n = len(F)
    pairs = list(itertools.combinations(range(n), 2))
    return sp.Matrix([[-F[m][a][b] for m in range(n)] for a, b in pairs])


def _delta2_matrix(F) -> sp.Matrix:
    """``delta_2: Lambda^2 g* -> Lambda^3 g*`` in the basis ``Theta_ab`` (``a < b``) by the printed
    invariant formula ``-Theta([u,v],w) + Theta([u,w],v) - Theta([v,w],u)``."""
    n = len(F)
    pairs = list(itertools.combinations(range(n), 2))
    triples = list(itertools.combinations(range(n), 3))
    syms = sp.symbols(f"t0:{len(pairs)}")
    T = sp.zeros(n, n)
    for s_, (a, b) in zip(syms, pairs):
        T[a, b], T[b, a] = s_, -s_

    def Th(vec_u, w):  # Theta(sum_k vec_u[k] e_k, e_w)
        return sum(vec_u[k] * T[k, w] for k in range(n))

    def br(a, b):
        return [F[m][a][b] for m in range(n)]

    rows = []
    for a, b, c in triples:
        e = -Th(br(a, b), c) + Th(br(a, c), b) - Th(br(b, c), a)
        rows.append([sp.diff(e, s_) for s_ in syms])
    return sp.Matrix(rows) if rows else sp.zeros(0, len(pairs))


def _cohomology_dims(F) -> tuple[int, int, int]:
    """``(dim H^1, dim Z^2, dim B^2)`` of the trivial module, by exact ranks."""
    n = len(F)
    d1 = _delta1_matrix(F)
    r1 = d1.rank() if d1.rows else 0
    d2 = _delta2_matrix(F)
    npairs = n * (n - 1) // 2
    z2 = npairs - (d2.rank() if d2.rows else 0)
    return n - r1, z2, r1


def _delta1_components(F, theta: sp.Matrix, form: str):
    """``<(delta_1 theta)(e_mu, e_nu)|e_alpha>`` with ``theta_{alpha,mu} = <theta(e_mu)|e_alpha>``
    (``theta[alpha, mu]``): ``form`` = ``definition`` (``k(u) = -ad(u)^T`` on ``g*``, the coadjoint
    representation, from the inline definition ``k(u)theta(v) - k(v)theta(u) - theta([u,v])``),
    ``printed`` (second row of the display) or ``corrected``."""
    n = len(F)
    out = {}
    for mu, nu, al in itertools.product(range(n), repeat=3):
        if form == "definition":
            # (k(u) lam)_alpha = -(ad(u)^T lam)_alpha = -sum_m u^a f^m_{a alpha} lam_m
            def k(u, lam):
                return [
                    -sum(u[a] * F[m][a][c] * lam[m] for a in range(n) for m in range(n))
                    for c in range(n)
                ]

            eu = [1 if i == mu else 0 for i in range(n)]
            ev = [1 if i == nu else 0 for i in range(n)]
            th_u = [theta[c, mu] for c in range(n)]
            th_v = [theta[c, nu] for c in range(n)]
            th_br = [sum(F[k_][mu][nu] * theta[c, k_] for k_ in range(n)) for c in range(n)]
            val = k(eu, th_v)[al] - k(ev, th_u)[al] - th_br[al]
        else:
            last = (
                sum(theta[k_, al] * F[k_][mu][nu] for k_ in range(n))
                if form == "printed"
                else sum(theta[al, k_] * F[k_][mu][nu] for k_ in range(n))
            )
            val = (
                -sum(theta[k_, nu] * F[k_][mu][al] for k_ in range(n))
                + sum(theta[k_, mu] * F[k_][nu][al] for k_ in range(n))
                - last
            )
        out[(mu, nu, al)] = sp.expand(val)
    return out


def _delta1_row1(F, theta):
    """First row of the display: ``-<theta(v)|[u,w]> + <theta(u)|[v,w]> - <theta([u,v])|w>``."""
    n = len(F)
    out = {}
    for mu, nu, al in itertools.product(range(n), repeat=3):
        val = (
            -sum(theta[k_, nu] * F[k_][mu][al] for k_ in range(n))
            + sum(theta[k_, mu] * F[k_][nu][al] for k_ in range(n))
            - sum(F[k_][mu][nu] * theta[al, k_] for k_ in range(n))
        )
        out[(mu, nu, al)] = sp.expand(val)
    return out


def _generic_theta(n):
    return sp.Matrix(n, n, lambda a, m: sp.Symbol(f"th{a}_{m}"))


def _su2_coboundary_theta(F):
    """An antisymmetric (symplectic) one-cocycle of su(2): ``theta(u) = k(u) eta``, i.e.
    ``theta_{alpha,mu} = -eta_k f^k_{mu alpha}``, with a rational ``eta``."""
    eta = [R(1, 3), R(-2, 5), R(3, 7)]
    n = len(F)
    return sp.Matrix(n, n, lambda al, mu: -sum(eta[k] * F[k][mu][al] for k in range(n)))


def _sept_delta1(form: str) -> Outcome:
    bad = []
    for name in ("su(2)", "sl(2,R)", "aff(1)", "h(3)"):
        F = algebras.structure_constants(name)
        th = _generic_theta(len(F))
        ref = _delta1_components(F, th, "definition")
        row1 = _delta1_row1(F, th)
        if any(sp.expand(row1[k] - ref[k]) != 0 for k in ref):
            bad.append(f"{name}: row 1")
        got = _delta1_components(F, th, form)
        nz = sum(1 for k in ref if sp.expand(got[k] - ref[k]) != 0)
        if nz:
            bad.append(f"{name}: {nz} of {len(ref)} components differ")
    # on the cocycle theta(u) = k(u) eta of su(2) (antisymmetric, so symplectic) the coboundary vanishes
    F = algebras.structure_constants("su(2)")
    th = _su2_coboundary_theta(F)
    val = _delta1_components(F, th, form)
    nz = sum(1 for v in val.values() if v != 0)
    if nz:
        bad.append(f"su(2) cocycle k(u)eta: {nz} nonzero components")
    return Outcome(
        not bad, None, None, "; ".join(bad) if bad else "exact on su(2), sl(2,R), aff(1), h(3)"
    )


def sept_delta1_printed() -> Outcome:
    """Appendix display 1, second row, as printed:
    ``<(delta_1 theta)(e_mu, e_nu)|e_alpha> = -theta_{k,nu} f^k_{mu alpha} + theta_{k,mu} f^k_{nu alpha}
    - theta_{k,alpha} f^k_{mu nu}``, against the definition (first row / inline ``k(u) = -ad(u)^T``),
    generic symbolic ``theta`` (exact). Expected to FAIL: the last term must be ``theta_{alpha,k}``."""
    return _sept_delta1("printed")


def sept_delta1_corrected() -> Outcome:
    """Corrected second row: ``... - theta_{alpha,k} f^k_{mu nu}`` (``<theta([e_mu,e_nu])|e_alpha>`` =
    ``f^k_{mu nu} theta_{alpha,k}`` since ``theta_{alpha,k} = <theta(e_k)|e_alpha>``)."""
    return _sept_delta1("corrected")


def sept_cocycle_to_zeven1() -> Outcome:
    """Sentences of the appendix: for an antisymmetric ``theta`` (symplectic cochain) and
    ``Theta_ab = theta_{a,b}``, ``delta_1 theta = 0`` (corrected components) is exactly zeven1:
    ``<(delta_1 theta)(e_mu,e_nu)|e_alpha> = (delta_2 Theta)(e_mu, e_alpha, e_nu)`` identically."""
    bad = []
    for name in ("su(2)", "sl(2,R)", "aff(1)", "h(3)", "u(2)"):
        F = algebras.structure_constants(name)
        n = len(F)
        T = sp.zeros(n, n)
        for a, b in itertools.combinations(range(n), 2):
            s_ = sp.Symbol(f"T{a}_{b}")
            T[a, b], T[b, a] = s_, -s_
        d1 = _delta1_components(F, T, "corrected")
        for mu, nu, al in d1:
            a, b, c = mu, al, nu
            z1 = (
                -sum(T[k, c] * F[k][a][b] for k in range(n))
                + sum(T[k, b] * F[k][a][c] for k in range(n))
                - sum(T[k, a] * F[k][b][c] for k in range(n))
            )
            if sp.expand(d1[(mu, nu, al)] - z1) != 0:
                bad.append(name)
                break
    return Outcome(
        not bad,
        None,
        None,
        f"failed: {bad}" if bad else "identity on su(2), sl(2,R), aff(1), h(3), u(2)",
    )


def sept_delta2_definition() -> Outcome:
    """Appendix display 2 (``delta_2``) with zeven1 as its components: ``delta_2 delta_1 = 0``
    (``-xi.f`` is always a cocycle, i.e. the Jacobi identity) exactly on every algebra of :data:`algebras.ALGEBRAS`,
    and the component form zeven1 equals the invariant form on basis vectors (by construction of
    :func:`_delta2_matrix` from the invariant form; zeven1 compared symbolically)."""
    bad = []
    for name in algebras.ALGEBRAS:
        F = algebras.structure_constants(name)
        n = len(F)
        if not _jacobi_ok(F):
            bad.append(f"{name}: Jacobi")
            continue
        d1, d2 = _delta1_matrix(F), _delta2_matrix(F)
        if d2.rows and not (d2 * d1).is_zero_matrix:
            bad.append(f"{name}: delta2 delta1 != 0")
        # zeven1 components vs the invariant formula
        pairs = list(itertools.combinations(range(n), 2))
        syms = sp.symbols(f"t0:{len(pairs)}")
        T = sp.zeros(n, n)
        for s_, (a, b) in zip(syms, pairs):
            T[a, b], T[b, a] = s_, -s_
        for i, (a, b, c) in enumerate(itertools.combinations(range(n), 3)):
            z1 = (
                -sum(T[k, c] * F[k][a][b] for k in range(n))
                + sum(T[k, b] * F[k][a][c] for k in range(n))
                - sum(T[k, a] * F[k][b][c] for k in range(n))
            )
            inv = sum(d2[i, j] * syms[j] for j in range(len(syms)))
            if sp.expand(z1 - inv) != 0:
                bad.append(f"{name}: zeven1 ({a}{b}{c})")
    return Outcome(
        not bad, None, None, f"failed: {bad}" if bad else f"exact on {', '.join(algebras.ALGEBRAS)}"
    )


def whitehead_semisimple() -> Outcome:
    """Whitehead lemmas (appendix): ``H^1(g, R) = 0`` and ``H^2(g, R) = 0`` for the semisimple
    su(2), sl(2,R), so(4) (exact ranks of ``delta_1``, ``delta_2``), hence every cocycle is
    ``Theta = -xi.f`` (zeven3)."""
    det = []
    ok = True
    for name in ("su(2)", "sl(2,R)", "so(4)"):
        h1, z2, b2 = _cohomology_dims(algebras.structure_constants(name))
        ok &= h1 == 0 and z2 == b2
        det.append(f"{name}: dim H^1 = {h1}, dim H^2 = {z2 - b2}")
    return Outcome(ok, None, None, "; ".join(det))


def semisimple_needed_counterexample() -> Outcome:
    """The hypothesis 'semisimple' of drie7 -- drie10 / zeven3 is needed: on the nilpotent h(3)
    (``[e1, e2] = e3``) ``Theta = eps^1 ^ eps^3`` is a cocycle (zeven1 holds) but no ``xi`` gives
    ``Theta = -xi.f`` (the linear system is inconsistent), so no ``pi' = pi + xi`` makes
    ``omega_I = -d(pi'_m eps_L^m)`` (drie8). It is not necessary: the solvable aff(1) has
    ``H^2 = 0`` (every cocycle is ``-xi.f``) although it is not semisimple; the exact condition is
    ``[Theta] = 0`` in ``H^2(g, R)``. Whitehead's ``H^1 = 0`` fails as well off the semisimple case
    (aff(1): ``dim H^1 = 1``), and on the abelian R^3 every ``Theta != 0`` is a non-trivial class
    (``dim H^2 = 3``). Passes when all these facts hold (exact)."""
    F = algebras.structure_constants("h(3)")
    n = 3
    T = sp.zeros(n, n)
    T[0, 2], T[2, 0] = 1, -1
    z1 = [
        -sum(T[k, c] * F[k][a][b] for k in range(n))
        + sum(T[k, b] * F[k][a][c] for k in range(n))
        - sum(T[k, a] * F[k][b][c] for k in range(n))
        for a, b, c in itertools.product(range(n), repeat=3)
    ]
    cocycle = all(sp.simplify(e) == 0 for e in z1)
    xi = sp.symbols("x0:3")
    eqs = [
        T[a, b] + sum(xi[m] * F[m][a][b] for m in range(n))
        for a, b in itertools.combinations(range(n), 2)
    ]
    no_xi = sp.solve(eqs, xi, dict=True) == []
    _h1, z2, b2 = _cohomology_dims(algebras.structure_constants("aff(1)"))
    aff_ok = z2 == b2
    _hh1, hz2, hb2 = _cohomology_dims(F)
    a1, _az2, _ab2 = _cohomology_dims(algebras.structure_constants("aff(1)"))
    _r1, rz2, rb2 = _cohomology_dims(algebras.structure_constants("R^3"))
    ok = cocycle and no_xi and aff_ok and a1 == 1 and rz2 - rb2 == 3
    return Outcome(
        ok,
        None,
        None,
        f"h(3): eps1^eps3 cocycle {cocycle}, no xi {no_xi}, dim H^2(h(3)) = {hz2 - hb2}; "
        f"aff(1) (solvable): dim H^2 = {z2 - b2}, dim H^1 = {a1}; R^3: dim H^2 = {rz2 - rb2}",
    )


def cocycle_needed_counterexample() -> Outcome:
    """'obviously closed' (introduction, trois, quatre, appendix): ``omega_L`` is closed iff the
    Poisson bracket of ``-W^-1`` satisfies Jacobi; with ``Upsilon = 0`` the momentum bracket is
    ``{pi_a, pi_b} = -(pi_k f^k_ab - Theta_ab)`` (drie3), whose Jacobiator is ``delta_2 Theta``
    up to sign. Closedness needs the cocycle condition zeven1: on u(2) = su(2) + R,
    ``Theta = eps^1 ^ eps^4`` is not a cocycle and the Jacobiator is nonzero; for a cocycle of
    u(2) (``eps^1 ^ eps^2``) it vanishes. Exact; passes when both hold."""
    F = algebras.structure_constants("u(2)")
    n = 4
    pi = sp.symbols("p0:4")

    def jacobiator(T):
        P = sp.Matrix(n, n, lambda a, b: -(sum(pi[k] * F[k][a][b] for k in range(n)) - T[a, b]))
        worst = 0
        for a, b, c in itertools.combinations(range(n), 3):
            e = sum(
                P[a, l] * sp.diff(P[b, c], pi[l])
                + P[b, l] * sp.diff(P[c, a], pi[l])
                + P[c, l] * sp.diff(P[a, b], pi[l])
                for l in range(n)
            )
            if sp.expand(e) != 0:
                worst += 1
        return worst

    bad = sp.zeros(n, n)
    bad[0, 3], bad[3, 0] = 1, -1
    good = sp.zeros(n, n)
    good[0, 1], good[1, 0] = 1, -1
    jb, jg = jacobiator(bad), jacobiator(good)
    return Outcome(
        jb > 0 and jg == 0,
        None,
        None,
        f"u(2): non-cocycle eps1^eps4 -> {jb} nonzero Jacobiator components; cocycle eps1^eps2 -> {jg}",
    )


def sept_xi_space_printed() -> Outcome:
    """'The constant vector xi in T*(g)': ``xi`` was just introduced as an element of
    ``C^1(g, R, 0) = g*`` (N components, one per basis vector: ``Theta_ab = -xi_m f^m_ab``), while
    ``T*(g) = g x g*`` has dimension 2N. Expected to FAIL: dimension 2N (T*g) vs N (xi)."""
    n = 3
    xi = sp.symbols("x0:3")
    return Outcome(
        len(xi) == 2 * n, None, None, f"xi has {len(xi)} components, dim T*(g) = {2 * n}"
    )


def sept_xi_space_corrected() -> Outcome:
    """Corrected: ``xi in g*`` (= ``C^1(g, R, 0)``): ``-xi.f`` spans ``B^2`` with ``xi`` of dimension N
    (su(2): ``delta_1`` is injective, rank 3 = N)."""
    F = algebras.structure_constants("su(2)")
    d1 = _delta1_matrix(F)
    return Outcome(
        d1.cols == 3 and d1.rank() == 3, None, None, "delta_1: g* (dim 3) -> Lambda^2, rank 3"
    )


CHECKS = {
    "zeven1_jacobi": zeven1_jacobi,
    "zeven3_whitehead": zeven3_whitehead,
    "sept_delta1_printed": sept_delta1_printed,
    "sept_delta1_corrected": sept_delta1_corrected,
    "sept_cocycle_to_zeven1": sept_cocycle_to_zeven1,
    "sept_delta2_definition": sept_delta2_definition,
    "whitehead_semisimple": whitehead_semisimple,
    "semisimple_needed_counterexample": semisimple_needed_counterexample,
    "cocycle_needed_counterexample": cocycle_needed_counterexample,
    "sept_xi_space_printed": sept_xi_space_printed,
    "sept_xi_space_corrected": sept_xi_space_corrected,
}
