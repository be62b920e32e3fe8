"""The registry beyond the labelled equations: every displayed formula and every mathematical sentence.

:mod:`oracles.paper_index` lists the paper's displays (``<section>.d<k>``) and mathematical
sentences (``<section>.s<k>``); this module gives each one an :class:`Entry`:

* labelled displays get theirs from the labelled registry :data:`oracles.claims.CLAIMS`
  (:func:`labelled_display_entry`, one entry per display even when it carries two labels);
* unlabelled displays and sentences are written out below (:data:`UNLABELLED`, :data:`SENTENCES`).

Statuses
    ``verified`` (the checks pass), ``erratum`` (a check of the printed form, ``literal``, FAILS and the
    checks of ``corrected`` pass), ``restriction`` (true only under a hypothesis the text does not
    state; ``corrected`` states it, the checks show both the restricted claim and the counterexample),
    ``definition`` (a definition or notation; checks, if any, show it is consistent) and
    ``not checkable`` (``reason`` says why).

Each entry names its evidence (checks of :mod:`oracles.claim_checks` and
:mod:`oracles.claim_checks_unlabelled`, precision, algebras); bounds say whether they are attained
(``attained``) and hypotheses whether they are needed (``needed``), with the example.

``quote`` anchors an entry to the text: it must occur in the printed LaTeX of the display, or in the
sentence (white space collapsed). :func:`coverage` compares the registry with the paper.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, replace

from .claim_checks import Outcome
from .claim_checks_unlabelled import run_check
from .claims import CLAIMS, Claim
from .paper_index import PaperIndex, normalise

__all__ = [
    "SENTENCES",
    "STATUSES",
    "UNLABELLED",
    "Entry",
    "coverage",
    "entries_for",
    "evaluate_entries",
    "fmt_outcome",
    "labelled_display_entry",
    "render_entries_markdown",
]

STATUSES = ("verified", "erratum", "restriction", "definition", "not checkable")

EXACT = "exact (sympy, symbolic or rational inputs)"
MP45 = "mpmath at 45 digits, tolerance 1e-22 (10^-(30-8)); su(2) as 2x2 matrices exp(x^a E_a)"


@dataclass(frozen=True)
class Entry:
    """One registry entry for a display or a sentence of the paper (see the module docstring)."""

    id: str
    quote: str
    claim: str
    status: str
    checks: tuple = ()
    literal: tuple = ()
    corrected: str = ""
    reason: str = ""
    evidence: str = ""
    attained: str = ""
    needed: str = ""
    labels: tuple = ()


def E(id_, quote, status, claim, **kw) -> Entry:
    for key in ("checks", "literal", "labels"):
        if key in kw and isinstance(kw[key], str):
            kw[key] = (kw[key],)
    return Entry(id_, quote, claim, status, **kw)


_TW1 = "twee1_frame_corrected"
_TW1P = "twee1_frame_printed"
_RF = "deux_right_frame_corrected"
_RFP = "deux_right_frame_printed"

# ------------------------------------------------------------------ unlabelled displays
UNLABELLED: tuple[Entry, ...] = (
    E(
        "un.d04",
        r"\widetilde{\phi}:\left(x^i,p_k\right)",
        "verified",
        "cotangent lift p'_k = p_l d(phi^-1)^l/dx'^k of a diffeomorphism; F' = (Dphi^-1)^T F Dphi^-1; "
        "B' = Dphi B Dphi^T",
        checks="un_lift_diffeomorphism",
        evidence=EXACT
        + "; phi(x,y) = (x, y(1+x^2)), F_12 = 1 + xy, B^12 = 3/2: the lift preserves "
        "dx^dp, F' pulls back to F, B' is the dp'^dp' coefficient of the transported omega_B",
        needed="B' is only the dp'^dp' coefficient: for non-affine phi the transported 1/2 B dp^dp also "
        "has dx'^dp' and dx'^dx' terms (same check), which is the paper's next sentence",
    ),
    E(
        "deux.d02",
        r"\pi^R_\mu=\langle p_g,\bfe_\mu^R\rangle=p_\nu\,{R^\nu}_\mu(g,e)",
        "erratum",
        "left and right trivialisations: pi^L_m = p_n L^n_m(g,e), pi^R_m = p_n R^n_m(g,e)",
        checks=(_TW1, _RF, "twee3_coadjoint"),
        literal=(_TW1P, _RFP),
        corrected="with the paper's definitions L^a_b(g,h) = d(gh)^a/dg^b, R^a_b(g,h) = d(hg)^a/dg^b both "
        "L(g,e) and R(g,e) are the identity and pi^L = pi^R = p; the derivatives must be taken in h: "
        "L^a_b(g,h) = d(gh)^a/dh^b, R^a_b(g,h) = d(hg)^a/dh^b. Then L(g,e) = phi1(-ad_x)^-1, "
        "R(g,e) = phi1(ad_x)^-1 and pi^R = Ad(g^-1)^T pi^L (twee3). Inherits the twee1 erratum; the "
        "right-handed half (R, not covered by the twee1 entry) is recorded here",
        evidence=MP45 + "; frames compared with d/ds x(g exp(s e_b)) and d/ds x(exp(s e_b) g)",
        labels=("twee1",),
    ),
    E(
        "deux.d16",
        r"D(g^{-1})\,\dif D(g)=D^\prime(g^{-1}\,\dif g)",
        "verified",
        "Maurer-Cartan form in a representation: D(g)^-1 dD(g) = D'(g^-1 dg)",
        checks="deux_maurer_cartan",
        evidence=MP45
        + "; D = spin-1/2, Ad (D' = ad), K = Ad(g^-1)^T (D' = k = -ad^T), i.e. also the "
        "inline dAd(g) = Ad(g) ad(e_m) eps_L^m and dK(g) = K(g) k(e_m) eps_L^m",
    ),
    E(
        "deux.d20",
        r"\Omega^\alpha_L\doteq{L^\alpha}_\beta(g^{-1},g)\,\frac{dg^\beta}{dt}=",
        "verified",
        "repetition of twee13: Omega_L = L(g^-1,g) dg/dt = I^-1 pi",
        checks="euler_equations",
        evidence=MP45
        + "; reference vector field (vier10 with Upsilon = 0) against the printed form",
        labels=("twee13",),
    ),
    E(
        "cinq.d02",
        r"X^\alpha\,\pi^\prime_\kappa\,{\ep^\kappa}_{\alpha\beta}-X_\beta=H_\beta",
        "verified",
        "components of i_X omega_L = dH for su(2): X^a pi'_k eps_kab - X_b = H_b, "
        "X^n + X_m tau_l eps_lmn = H^n",
        checks=("cinq_component_equations", "cinq_nondegenerate"),
        evidence=EXACT + "; X^T W with W of vijf1, symbolic X, pi', tau",
    ),
    E(
        "cinq.d04",
        r"{(\Psi^{-1})^\beta}_\nu=(C_1)^{-1}",
        "verified",
        "explicit inverses (Psi^-1)^b_n = (delta - pi'^b tau_n)/C1, (Phi^-1)_n^b = (delta - tau_n pi'^b)/C1",
        checks=("cinq_explicit_matrices", "cinq_nondegenerate"),
        evidence=EXACT + "; Phi Phi^-1 = Phi^-1 Phi = 1 and the same for Psi with Phi = 1 + S U, "
        "Psi = 1 + U S from vier6, symbolic pi', tau (valid where C1 != 0)",
    ),
    E(
        "cinq.d13",
        r"-(1/\tau)\,X^2+\pi^\prime_2\,X^3-X_1&=&\langle\dif V|\bfe^L_1\rangle",
        "verified",
        "the six component equations of vijf11 on Pi_1 (tau = (0,0,tau), pi'_3 = 1/tau)",
        checks=("cinq_degenerate", "cinq_component_equations"),
        evidence=EXACT + "; the printed six rows equal X^T W - dH^T with W restricted to Pi_1 "
        "(oracles.su2_symbolic residual 'vijf11')",
        labels=("vijf11",),
    ),
    E(
        "sept.d01",
        r"-\,\theta_{\kappa,\alpha}\;{{\bf f}^\kappa}_{\mu\nu}=0",
        "erratum",
        "coboundary of a one-cochain theta in C^1(g, g*, k): invariant form and components",
        checks=("sept_delta1_corrected", "sept_cocycle_to_zeven1"),
        literal="sept_delta1_printed",
        corrected="second row: <(delta_1 theta)(e_mu,e_nu)|e_alpha> = -theta_{k,nu} f^k_{mu alpha} + "
        "theta_{k,mu} f^k_{nu alpha} - theta_{alpha,k} f^k_{mu nu} (printed: theta_{k,alpha}). With "
        "theta_{alpha,mu} = <theta(e_mu)|e_alpha> (the paper's definition), <theta([e_mu,e_nu])|e_alpha> = "
        "f^k_{mu nu} theta_{alpha,k}. The first row (invariant form) is right. For an antisymmetric "
        "(symplectic) theta the printed last term has the wrong sign, and the printed condition rejects "
        "the su(2) cocycle theta(u) = k(u) eta",
        evidence=EXACT
        + "; generic symbolic theta on su(2), sl(2,R), aff(1), h(3): printed row differs "
        "from the definition (k(u) = -ad(u)^T) in 12/27, 12/27, 2/8, 4/27 components; corrected row "
        "equals it; with the correction, antisymmetric theta in Z^1 <=> zeven1 (identity on 5 algebras)",
    ),
    E(
        "sept.d02",
        r"(\delta_2\Theta)(\bu,\bv,\bw)\doteq",
        "definition",
        "delta_2 Theta(u,v,w) = -Theta([u,v],w) + Theta([u,w],v) - Theta([v,w],u)",
        checks="sept_delta2_definition",
        evidence=EXACT + "; consistent: delta_2 delta_1 = 0 and its basis components are zeven1 on "
        "su(2), sl(2,R), so(4), aff(1), h(3), u(2), R^3",
    ),
)

# ------------------------------------------------------------------ mathematical sentences
_HYP_COCYCLE = (
    "needed: closedness of omega_L requires Theta to be a cocycle (zeven1) and Upsilon constant; "
    "counterexample on u(2) = su(2)+R: Theta = eps^1^eps^4 is not a cocycle and the Jacobiator of "
    "{pi_a, pi_b} = -(pi.f - Theta)_ab is nonzero (cocycle_needed_counterexample)"
)
_HYP_SEMISIMPLE = (
    "needed: some hypothesis is (h(3): Theta = eps^1^eps^3 is a cocycle with no xi, dim H^2 = 2; "
    "R^3: dim H^2 = 3); semisimplicity is sufficient, not necessary (aff(1), solvable, has H^2 = 0): "
    "the exact condition is [Theta] = 0 in H^2(g, R)"
)

SENTENCES: tuple[Entry, ...] = (
    E(
        "abstract.s01",
        "we studied an extension of the canonical symplectic structure",
        "not checkable",
        "summary of the authors' earlier work on T*R^N",
        reason="a report on another paper; its formulas een1-een3 are checked in the labelled registry",
    ),
    E(
        "un.s01",
        "we examined such an extension of the canonical symplectic two-form",
        "definition",
        "Omega = omega_0 + omega_F + omega_B on T*R^N",
        reason="introduces een1",
    ),
    E(
        "un.s02",
        "is function of both variables",
        "verified",
        "for a general diffeomorphism B' depends on p' and x', so omega_B has no intrinsic meaning",
        checks="un_lift_diffeomorphism",
        evidence=EXACT
        + "; phi(x,y) = (x, y(1+x^2)): B' = (1+x^2) B depends on x', and the transported "
        "omega_B has dx^dp terms ('no intrinsic meaning' is the interpretation)",
    ),
    E(
        "un.s03",
        "has two distinguished trivialisations",
        "verified",
        "T*G has a left and a right trivialisation by invariant forms",
        checks=(_TW1, _RF),
        evidence=MP45
        + "; left and right invariant frames and their dual coframes (corrected twee1)",
    ),
    E(
        "un.s04",
        "we use the left trivialisation with left invariant",
        "not checkable",
        "plan of section deux",
        reason="describes what the paper does next",
    ),
    E(
        "un.s05",
        "arises from a symplectic one-cocycle",
        "verified",
        "constant F gives omega_F from a symplectic one-cocycle; constant B gives a left-invariant omega_B",
        checks=("zeven1_jacobi", "deux_lifted_action", "cocycle_needed_counterexample"),
        evidence=EXACT
        + " (closedness <=> zeven1 on 8 algebras in tests) and "
        + MP45
        + " (pi^L, hence "
        "dpi^L, invariant under the lifted left action)",
        needed=_HYP_COCYCLE,
    ),
    E(
        "un.s06",
        "is obviously closed but the non degeneracy condition",
        "verified",
        "Omega (omega_L) is closed; non-degeneracy fails on a set, giving a constrained system",
        checks=(
            "vier2_closed",
            "zeven1_jacobi",
            "cocycle_needed_counterexample",
            "quatre_detW_equals_Delta",
            "cinq_degenerate",
        ),
        evidence="Jacobiator of the reference Poisson tensor at 45 digits (su(2)); det W = Delta exactly "
        "(5 algebras); su(2): omega_L has rank 4 on Pi_1 = {C1 = 0}, non-empty when tau != 0",
        needed=_HYP_COCYCLE,
    ),
    E(
        "deux.s01",
        "define left- and right invariant vector fields and one forms",
        "definition",
        "e^L = L_{g*} e, e^R = R_{g*} e, eps_L = L*_{g^-1} eps, eps_R = R*_{g^-1} eps",
        checks=(_TW1, _RF),
        evidence=MP45
        + "; these invariant definitions are the judges of the coordinate forms (twee1)",
    ),
    E(
        "deux.s02",
        'the "body" coordinates',
        "definition",
        "left trivialisation = body coordinates",
        reason="naming",
    ),
    E(
        "deux.s03",
        'yields "space" coordinates',
        "definition",
        "right trivialisation = space coordinates",
        reason="naming",
    ),
    E(
        "deux.s04",
        "Both are related through the coadjoint representation",
        "verified",
        "pi^R = Ad(g^-1)^T pi^L (twee3)",
        checks="twee3_coadjoint",
        evidence=MP45,
        labels=("twee3",),
    ),
    E(
        "deux.s05",
        "yields a group action",
        "verified",
        "the lift of left multiplication acts as (g, pi^L) -> (ag, pi^L) in body coordinates",
        checks="deux_lifted_action",
        evidence=MP45 + "; pi^L(ag, L*_{a^-1} p) = pi^L(g, p) with corrected L(g,e)",
    ),
    E(
        "deux.s06",
        "invariant one forms on $T^\\star(G)$",
        "verified",
        "kappa* eps_L and dpi^L are invariant under the lifted left action",
        checks="deux_lifted_action",
        evidence=MP45 + "; eps_L(ag) d(ah)/dh = eps_L(g) and pi^L invariant",
    ),
    E(
        "deux.s07",
        "provide a left invariant basis of the cotangent space",
        "verified",
        "(eps_L, dpi^L) is a left-invariant coframe of T*G (twee4)",
        checks=(_TW1, "deux_lifted_action"),
        evidence=MP45
        + "; L(g^-1,g) L(g,e) = 1 (a basis) and invariance; the printed coordinate form "
        "of twee4 inherits the twee1 erratum",
        labels=("twee4",),
    ),
    E(
        "deux.s08",
        "Its dual basis in the tangent space",
        "verified",
        "(e^L, d/dpi) is the dual frame (twee5)",
        checks=_TW1,
        evidence=MP45 + "; L(g^-1,g) L(g,e) = 1 with the corrected L",
        labels=("twee5",),
    ),
    E(
        "deux.s09",
        "The canonical Liouville one-form",
        "verified",
        "theta_0 = p dg, omega_0 = -d theta_0 = dg^dp, expressed in the frame as twee6",
        checks="liouville_forms",
        evidence=MP45 + "; -d(pi_m eps_L^m) computed by differentiation equals the frame matrix",
        labels=("twee6",),
    ),
    E(
        "deux.s10",
        "is the inverse of a constant, positive definite",
        "definition",
        "I^ab is the inverse of a constant positive definite inertia tensor",
        reason="hypothesis on the data (twee10)",
    ),
    E(
        "deux.s11",
        "is a function $V$ defined on the group manifold",
        "definition",
        "V is a function on G",
        reason="definition",
    ),
    E(
        "deux.s12",
        "gravitational potential energy",
        "definition",
        "announces twee15",
        reason="definition of an example",
    ),
    E(
        "deux.s13",
        "denotes the canonical pairing",
        "definition",
        "( | ) is the pairing of g and g*",
        reason="notation",
    ),
    E(
        "trois.s01",
        "obeys the cocycle condition {\\bf(\\ref{zeven1})}, then",
        "verified",
        "if Theta satisfies zeven1, Theta_L is a closed left-invariant two-form on G",
        checks=("zeven1_jacobi", "cocycle_needed_counterexample"),
        evidence=EXACT
        + "; zeven1 and the Jacobi identity of drie3 cut out the same space of Theta",
        needed=_HYP_COCYCLE,
        labels=("zeven1", "zeven2"),
    ),
    E(
        "trois.s02",
        "one obtains another symplectic two-form",
        "verified",
        "omega_I = omega_0 - Theta_L is symplectic and invariant under the lifted left action",
        checks=("quatre_detW_equals_Delta", "vier2_closed", "deux_lifted_action"),
        evidence="Upsilon = 0 gives Phi = 1, Delta = 1 (exact, 5 algebras); closedness at 45 digits; "
        "invariance of the frame at 45 digits",
        needed=_HYP_COCYCLE,
        labels=("drie1",),
    ),
    E(
        "trois.s03",
        "is maintained",
        "verified",
        "pi = I Omega still holds (drie4) and drie6 adds the interaction",
        checks="euler_equations",
        evidence=MP45,
        labels=("drie4", "drie6"),
    ),
    E(
        "trois.s04",
        "For a semisimple Lie algebra",
        "verified",
        "for semisimple g, Theta = -xi.f, and the modified Liouville form drie7 exists",
        checks=(
            "whitehead_semisimple",
            "zeven3_whitehead",
            "liouville_forms",
            "semisimple_needed_counterexample",
        ),
        evidence=EXACT
        + " (H^2 = 0 for su(2), sl(2,R), so(4)); "
        + MP45
        + " (-d theta_I = omega_I)",
        needed=_HYP_SEMISIMPLE,
        labels=("drie7", "zeven3"),
    ),
    E(
        "trois.s05",
        "are Darboux coordinates",
        "verified",
        "(g, p' = p + xi L(g^-1,g)) are Darboux coordinates of omega_I",
        checks="drie9_darboux",
        evidence=MP45
        + "; with the corrected L(g^-1,g) = phi1(-ad_x); the text 'This means that such "
        "that' is garbled and '(g^{-1};g)' has a semicolon for a comma (typographical)",
        needed=_HYP_SEMISIMPLE,
        labels=("drie9",),
    ),
    E(
        "trois.s06",
        "obviously are equivalent to",
        "verified",
        "drie11/drie12 are equivalent to drie4/drie5",
        checks="euler_equations",
        evidence=MP45 + "; the drie12 form in pi' and the drie5 form agree with the reference",
        labels=("drie11", "drie12"),
    ),
    E(
        "quatre.s01",
        "addition of a left-invariant and closed two-form",
        "verified",
        "Upsilon^L is left-invariant and closed, and adding it makes {g, g} != 0",
        checks=("vier2_closed", "deux_lifted_action", "quatre_identities"),
        evidence="closedness at 45 digits; vier9 {g,g} = -L L U Phi^-1 exactly (nonzero for U != 0)",
        needed="Upsilon must be constant (a pi-dependent Upsilon^mn dpi_m^dpi_n need not be closed)",
        labels=("vier1",),
    ),
    E(
        "quatre.s02",
        "They are mutually transposed",
        "verified",
        "Psi = Phi^T; Phi S = S Psi and U Phi = Psi U are antisymmetric",
        checks="quatre_identities",
        evidence=EXACT
        + "; su(2) here, 8 algebras x 2 seeds in tests/test_claims.py::test_quatre_identities",
        needed="uses only that S and Upsilon are antisymmetric (true by construction)",
        labels=("vier6",),
    ),
    E(
        "quatre.s03",
        "has a solution if $\\Phi$ and $\\Psi$ have inverses",
        "verified",
        "vier4 is solvable for every A if Delta != 0",
        checks=("quatre_identities", "quatre_detW_equals_Delta"),
        evidence=EXACT + "; det W = Delta, so the condition is also necessary (an 'iff')",
        labels=("vier7",),
    ),
    E(
        "quatre.s04",
        "are then also antisymmetric",
        "verified",
        "U Phi^-1 = Psi^-1 U and Phi^-1 S = S Psi^-1 are antisymmetric",
        checks="quatre_identities",
        evidence=EXACT,
        labels=("vier7",),
    ),
    E(
        "quatre.s05",
        "is a polynomial in $\\pi^L$ of degree at most equal to $N$",
        "verified",
        "Delta is a polynomial in pi of degree <= N",
        checks=("vier12_degree", "vier12_degree_attained"),
        evidence=EXACT
        + "; degrees: aff(1) 2 (N=2), su(2) 2, sl(2,R) 2, h(3) 2 (N=3), u(2) 2 (N=4), "
        "so(4) 4 (N=6)",
        attained="attained on aff(1) (N = 2, Delta = (1 - u(pi_2 - Theta_12))^2); never for odd N: the "
        "degree-N part is det(pi.f) det(Upsilon) = 0 (odd antisymmetric matrices are singular), so "
        "su(2)/SU(2) has degree 2 = N - 1; for even N it needs det(pi.f) != 0 (a Frobenius algebra): "
        "u(2), so(4) stay below N",
        labels=("vier12",),
    ),
    E(
        "quatre.s06",
        "It defines an algebraic variety",
        "definition",
        "Pi_1 = {Delta = 0} is an algebraic variety",
        checks="vier12_degree",
        evidence=EXACT + " (Delta is a polynomial)",
        labels=("vier12",),
    ),
    E(
        "quatre.s07",
        "defines a manifold",
        "not checkable",
        "the complement of Pi_1 is a manifold",
        reason="topology: the zero set of the continuous Delta is closed, so its complement is an open "
        "subset of g*, hence a manifold; nothing to compute",
        labels=("vier13",),
    ),
    E(
        "quatre.s08",
        "with symplectic structure given by $\\omega_L$",
        "verified",
        "omega_L is symplectic on M_0'",
        checks=("vier2_closed", "quatre_detW_equals_Delta"),
        evidence="closed (45 digits) and det W = Delta != 0 there (exact)",
    ),
    E(
        "quatre.s09",
        "itself is an algebraic manifold, an imbedded submanifold is obtained",
        "verified",
        "if Pi_1 is a manifold, M_1 = G x Pi_1 is an embedded submanifold",
        checks="cinq_plane",
        evidence=EXACT
        + "; su(2): Pi_1 is the plane C1 = 0 (dC1 = -tau != 0); note dDelta = 0 on Pi_1 "
        "(Delta = C1^2), so the regular-value description must use C1, not Delta",
        labels=("vier14",),
    ),
    E(
        "quatre.s10",
        "The system is then constrained",
        "not checkable",
        "the dynamics is restricted to M_1",
        reason="a statement of method (GNH); its su(2) execution is checked (cinq_gnh)",
    ),
    E(
        "quatre.s11",
        "semi-simple group $SU(2)$",
        "verified",
        "SU(2) is semisimple",
        checks=("whitehead_semisimple", "cinq_explicit_matrices"),
        evidence=EXACT + "; Killing form -2 delta non-degenerate, H^1 = H^2 = 0",
    ),
    E(
        "cinq.s01",
        "provides an isomorphism between $su(2)$",
        "verified",
        "Killing metric eps^m_an eps^n_bm = -2 delta_ab, an isomorphism su(2) -> su(2)*",
        checks="cinq_explicit_matrices",
        evidence=EXACT,
    ),
    E(
        "cinq.s02",
        "will be freely used to raise or to lower indices",
        "definition",
        "delta raises and lowers indices",
        reason="notation",
    ),
    E(
        "cinq.s03",
        "any antisymmetric $\\Upsilon$ can be written",
        "verified",
        "every cocycle of su(2) is Theta = -xi.eps; every antisymmetric Upsilon is tau.eps",
        checks=("whitehead_semisimple", "zeven3_whitehead"),
        evidence=EXACT + "; dim B^2 = dim Z^2 = 3 = dim Lambda^2; printed 'Y^{mu nu}' stands for "
        "Upsilon^{mu nu} (typographical)",
    ),
    E(
        "cinq.s04",
        "They obey ${\\Phi_\\alpha}^\\nu",
        "verified",
        "Phi (1 - tau pi'^T) = C1 1, Psi (1 - pi' tau^T) = C1 1",
        checks=("cinq_explicit_matrices", "cinq_nondegenerate"),
        evidence=EXACT,
    ),
    E(
        "cinq.s05",
        "It follows that {\\bf(\\ref{vier5})} implies",
        "verified",
        "vier5 implies vijf2, vijf3",
        checks="cinq_nondegenerate",
        evidence=EXACT,
        labels=("vijf2", "vijf3"),
    ),
    E(
        "cinq.s06",
        "The determinant of the matrices",
        "verified",
        "det Phi = det Psi = C1^2",
        checks="cinq_explicit_matrices",
        evidence=EXACT,
    ),
    E(
        "cinq.s07",
        "Obviously the plane",
        "restriction",
        "Pi_1 = {1 - pi'.tau = 0} is an algebraic manifold (a plane) in g*",
        checks="cinq_plane",
        corrected="a plane only for tau != 0 (tau = 0: C1 = 1 and Pi_1 is empty); Pi_1 is written as a set "
        "of pairs (g, pi) but said to lie in g*",
        evidence=EXACT,
        needed="tau != 0 is needed for a plane: tau = 0 gives the empty set (same check)",
    ),
    E(
        "cinq.s08",
        "with symplectic structure $\\omega_L$, retricted",
        "verified",
        "omega_L is symplectic off Pi_1",
        checks=("cinq_explicit_matrices", "quatre_detW_equals_Delta", "vier2_closed"),
        evidence=EXACT + "; Delta = C1^2 != 0 off Pi_1",
    ),
    E(
        "cinq.s09",
        "have inverses :",
        "verified",
        "Phi and Psi are invertible on M_0'",
        checks="cinq_explicit_matrices",
        evidence=EXACT,
    ),
    E(
        "cinq.s10",
        "defines a two dimensional plane",
        "restriction",
        "C1 = 0 is a two-dimensional plane in su(2)* = R^3",
        checks="cinq_plane",
        corrected="for tau != 0 (the next sentence derives tau != 0 on Pi_1, but the set is empty for tau = 0)",
        evidence=EXACT,
        needed="tau != 0 (counterexample tau = 0: C1 = 1, Pi_1 empty)",
    ),
    E(
        "cinq.s11",
        "is imbedded in",
        "verified",
        "M_1 = SU(2) x Pi_1 is embedded in M_0 by j_1",
        checks=("cinq_degenerate", "cinq_plane"),
        evidence=EXACT + "; vijf6, vijf7",
        labels=("vijf6", "vijf7"),
    ),
    E(
        "cinq.s12",
        "is degenerate and the pairing",
        "verified",
        "on M_1, omega_L is degenerate and pi'.tau = 1",
        checks="cinq_degenerate",
        evidence=EXACT + "; rank W = 4 on Pi_1",
    ),
    E(
        "cinq.s13",
        "greek indices",
        "definition",
        "index ranges",
        reason="notation",
    ),
    E(
        "cinq.s14",
        "five dimensional manifold",
        "verified",
        "the pull-back of omega_L lives on the 5-manifold M_1",
        checks="cinq_degenerate",
        evidence=EXACT + "; vijf9: W with the dpi_3 row and column deleted, rank 4",
        labels=("vijf9",),
    ),
    E(
        "cinq.s15",
        "Following the GNH algorithm",
        "definition",
        "the GNH problem: X in (TM_0)|1 tangent to M_1 solving vijf11",
        checks="cinq_gnh",
        evidence="refimpl.gnh on the worked examples reproduces hand-derived outcomes",
        labels=("vijf11",),
    ),
    E(
        "cinq.s16",
        "Two independent null vectors",
        "verified",
        "Z^1, Z^2 are independent and span the kernel of omega_L|1",
        checks="cinq_degenerate",
        evidence=EXACT + "; Z^T W = 0, rank [Z^1 Z^2] = 2, rank W = 4",
        labels=("vijf12",),
    ),
    E(
        "cinq.s17",
        "Consistency requires",
        "verified",
        "<dH|Z^a> = 0 (a = 1,2) and pi'_3 = 1/tau",
        checks="cinq_degenerate",
        evidence=EXACT + "; <dH|Z^a> = -C2a",
        labels=("vijf13",),
    ),
    E(
        "cinq.s18",
        "These two equations define a secondary constrained manifold",
        "restriction",
        "C21 = C22 = 0 define a submanifold M_2 of M_1 carrying the particular solution vijf14",
        checks=("cinq_degenerate", "cinq_gnh"),
        corrected="a submanifold only where dC21, dC22 are independent on M_1; they may vanish "
        "identically (M_2 = M_1) or have no common zero on M_1 (M_2 empty)",
        evidence=EXACT + "; vijf14 solves vijf11 exactly on M_2; worked examples",
        needed="free spherical top, xi = 0: C21 = C22 = 0 identically (M_2 = M_1, 'gauge'); free "
        "spherical top, xi = (1,0,0): C22 = -pi_3/2 != 0 on M_1 (M_2 empty, 'inconsistent') "
        "(oracles.gnh_examples)",
        labels=("vijf13", "vijf14"),
    ),
    E(
        "cinq.s19",
        "still contains two arbitrary functions",
        "verified",
        "X_G = X_P + zeta_1 Z^1 + zeta_2 Z^2 on M_2",
        checks="cinq_degenerate",
        evidence=EXACT + "; X_G - X_P in the kernel, which is 2-dimensional",
        labels=("vijf15",),
    ),
    E(
        "cinq.s20",
        "This vector must be tangent",
        "definition",
        "GNH tangency requirement",
        checks="cinq_degenerate",
        evidence=EXACT + "; vijf16: <dC1|X_G> = -tau X_G3",
        labels=("vijf16",),
    ),
    E(
        "cinq.s21",
        "will depend on the kinetic energy",
        "verified",
        "whether vijf16 fixes zeta_1, zeta_2 depends on K and V",
        checks="cinq_gnh",
        evidence="worked examples with different K, V end 'determined', 'gauge' (zeta free) and "
        "'inconsistent' (oracles.gnh_examples)",
        labels=("vijf16",),
    ),
    E(
        "cinq.s22",
        "tertiary constraint manifold",
        "not checkable",
        "otherwise a tertiary constraint M_3 follows",
        reason="the next step of the algorithm, stated generally; no worked example of the registry "
        "reaches a tertiary constraint",
    ),
    E(
        "six.s01",
        "which is then symplectic",
        "verified",
        "in the non-degenerate case omega_L is closed and symplectic",
        checks=("vier2_closed", "quatre_detW_equals_Delta"),
        evidence="closedness at 45 digits; det W = Delta exactly",
        needed=_HYP_COCYCLE,
    ),
    E(
        "sept.s01",
        "It is a one-cocycle",
        "definition",
        "delta_1 theta(u,v) = k(u)theta(v) - k(v)theta(u) - theta([u,v])",
        checks="sept_delta1_corrected",
        evidence=EXACT + "; with k(u) = -ad(u)^T this equals the first row of sept.d01",
    ),
    E(
        "sept.s02",
        "is called symplectic",
        "definition",
        "symplectic one-cocycle: Sigma antisymmetric",
        reason="definition",
    ),
    E(
        "sept.s03",
        "is actually a 2-cochain",
        "definition",
        "an antisymmetric theta defines Theta in C^2(g, R, 0)",
        reason="definition (antisymmetric bilinear forms are 2-cochains)",
    ),
    E(
        "sept.s04",
        "is a 2-cocycle",
        "verified",
        "theta in Z^1 (antisymmetric) => Theta in Z^2",
        checks=("sept_cocycle_to_zeven1", "sept_delta1_corrected"),
        evidence=EXACT + "; with the corrected components of sept.d01 the two conditions coincide "
        "(su(2), sl(2,R), aff(1), h(3), u(2)); with the printed components they do not",
        needed="antisymmetry of theta is assumed (sept.s03)",
    ),
    E(
        "sept.s05",
        "In general let",
        "definition",
        "Theta obeys zeven1",
        reason="hypothesis for zeven2",
    ),
    E(
        "sept.s06",
        "yields the left-invariant two form",
        "definition",
        "Theta_L = L*_{g^-1} Theta is left-invariant",
        reason="left-invariant by construction (zeven2)",
        labels=("zeven2",),
    ),
    E(
        "sept.s07",
        "it is seen that $\\Theta_L(g)$ is a closed",
        "verified",
        "Theta_L is closed",
        checks=("zeven1_jacobi", "cocycle_needed_counterexample"),
        evidence=EXACT,
        needed=_HYP_COCYCLE,
        labels=("zeven2",),
    ),
    E(
        "sept.s08",
        "is semisimple, $\\Theta$ is exact",
        "verified",
        "semisimple => every 2-cocycle is a coboundary",
        checks=("whitehead_semisimple", "zeven3_whitehead", "semisimple_needed_counterexample"),
        evidence=EXACT + "; su(2), sl(2,R), so(4)",
        needed=_HYP_SEMISIMPLE,
        labels=("zeven3",),
    ),
    E(
        "sept.s09",
        "the Whitehead lemmas state",
        "verified",
        "H^1(g, R) = H^2(g, R) = 0 for semisimple g",
        checks=("whitehead_semisimple", "semisimple_needed_counterexample"),
        evidence=EXACT + "; su(2), sl(2,R), so(4) by exact ranks of delta_1, delta_2",
        needed="semisimplicity is needed for both: aff(1) has H^1 = 1; h(3) has H^2 = 2",
    ),
    E(
        "sept.s10",
        "is a coboundary and there exists an element",
        "verified",
        "Theta = delta_1 xi = -xi([u,v]) for some xi in g*",
        checks=("zeven3_whitehead", "sept_xi_space_corrected"),
        evidence=EXACT,
        labels=("zeven3",),
    ),
    E(
        "sept.s11",
        "The constant vector $\\xi\\in T^\\star(\\LG)$",
        "erratum",
        "xi in T*(g) is the analogue of a magnetic field for G = R^3",
        checks=("sept_xi_space_corrected", "semisimple_needed_counterexample"),
        literal="sept_xi_space_printed",
        corrected="xi in g* (= C^1(g, R, 0), as the previous sentence says), not T*(g) = g x g*. The "
        "analogy is not checkable; note that for the abelian R^3, -xi.f = 0 and every Theta != 0 is a "
        "non-trivial class (dim H^2 = 3): the magnetic field is Theta itself, not a xi",
        evidence=EXACT,
    ),
)


# ------------------------------------------------------------------ labelled displays
# Bounds and hypotheses carried by labelled equations: extra checks and the attained / needed notes.
_DEGREE = {
    "checks": ("vier12_degree_attained",),
    "attained": "Delta's degree <= N is attained on aff(1) (N = 2) and never for odd N (su(2): 2 = N - 1); "
    "see quatre.s05",
}
_SEMI = {
    "checks": ("semisimple_needed_counterexample", "whitehead_semisimple"),
    "needed": _HYP_SEMISIMPLE,
}
_CLOSED = {"checks": ("cocycle_needed_counterexample",), "needed": _HYP_COCYCLE}
LABEL_NOTES = {
    "vier12": _DEGREE,
    "drie7": _SEMI,
    "drie8": _SEMI,
    "drie9": _SEMI,
    "drie10": _SEMI,
    "zeven3": _SEMI,
    "drie1": _CLOSED,
    "vier2": _CLOSED,
    "zeven2": _CLOSED,
    "vier7": {
        "checks": ("quatre_detW_equals_Delta",),
        "needed": "Delta != 0 is necessary as well as sufficient: det W = Delta (exact)",
    },
}


def labelled_display_entry(display_id: str, labels: tuple, latex: str, claims=CLAIMS) -> Entry:
    """The entry of a labelled display, from the labelled registry (second ``drie5`` = ``drie12``):
    erratum if one of its labels is, else verified if one is, else definition / not checkable."""
    by = {c.label: c for c in claims}
    cs: list[Claim] = [by[lab] for lab in labels]
    statuses = {c.status for c in cs}
    if "erratum" in statuses:
        status = "erratum"
    elif "verified" in statuses:
        status = "verified"
    else:
        status = (
            "definition"
            if all(c.reason.startswith("a definition") for c in cs)
            else "not checkable"
        )
    notes = [LABEL_NOTES[lab] for lab in labels if lab in LABEL_NOTES]
    checks = tuple(
        dict.fromkeys([n for c in cs for n in c.checks] + [n for x in notes for n in x["checks"]])
    )
    literal = tuple(dict.fromkeys(n for c in cs for n in c.literal))
    return Entry(
        display_id,
        quote=f"\\label{{{labels[0]}}}",
        claim="; ".join(c.claim for c in cs),
        status=status,
        checks=checks,
        literal=literal,
        corrected=" / ".join(c.erratum for c in cs if c.erratum),
        reason=" / ".join(c.reason for c in cs if c.reason),
        evidence=" / ".join(c.remark for c in cs if c.remark),
        attained=" / ".join(dict.fromkeys(x["attained"] for x in notes if "attained" in x)),
        needed=" / ".join(dict.fromkeys(x["needed"] for x in notes if "needed" in x)),
        labels=tuple(labels),
    )


def _renamed(labels_in_order):
    seen, out = set(), []
    for lab in labels_in_order:
        out.append("drie12" if lab == "drie5" and lab in seen else lab)
        seen.add(lab)
    return out


def entries_for(index: PaperIndex) -> list[tuple[object, Entry | None]]:
    """Pair every display and sentence of ``index`` with its entry (``None`` when the registry has
    none), in the paper's order."""
    all_labels = _renamed([lab for d in index.displays for lab in d.labels])
    it = iter(all_labels)
    unl = {e.id: e for e in UNLABELLED}
    sen = {e.id: e for e in SENTENCES}
    out: list[tuple[object, Entry | None]] = []
    for d in index.displays:
        if d.labels:
            labs = tuple(next(it) for _ in d.labels)
            known = {c.label for c in CLAIMS}
            e = labelled_display_entry(d.id, labs, d.latex) if set(labs) <= known else None
            if e is not None:  # anchor on the label as printed (drie12 is printed drie5)
                e = replace(e, quote=f"\\label{{{d.labels[0]}}}")
            out.append((d, e))
        else:
            out.append((d, unl.get(d.id)))
    for s in index.sentences:
        out.append((s, sen.get(s.id)))
    return out


def coverage(index: PaperIndex) -> dict:
    """Counts and the mismatches between the paper's items and the registry:
    ``missing`` (items without an entry), ``misanchored`` (entry whose ``quote`` is not in the item's
    text), ``extra`` (entries naming no item of the paper)."""
    pairs = entries_for(index)
    missing = [item.id for item, e in pairs if e is None]
    mis = []
    for item, e in pairs:
        if e is None:
            continue
        text = normalise(item.latex if hasattr(item, "latex") else item.text)
        if normalise(e.quote) not in text:
            mis.append(item.id)
    ids = {item.id for item, _ in pairs}
    extra = [e.id for e in UNLABELLED + SENTENCES if e.id not in ids]
    nd, ns = len(index.displays), len(index.sentences)
    with_entry = sum(1 for _, e in pairs if e is not None)
    return {
        "displays": nd,
        "labelled_displays": sum(1 for d in index.displays if d.labels),
        "sentences": ns,
        "items": nd + ns,
        "entries": with_entry,
        "missing": missing,
        "misanchored": mis,
        "extra": extra,
    }


# ------------------------------------------------------------------ evaluation and report
@dataclass
class EntryObservation:
    item: object
    entry: Entry
    verdict: str
    results: dict


def evaluate_entries(index: PaperIndex) -> list[EntryObservation]:
    """Run each entry's checks (cached; each once) and compare with its status.

    verified -> all ``checks`` pass; erratum / restriction -> all ``checks`` pass and all ``literal``
    checks fail; definition -> its ``checks`` (if any) pass; otherwise ``CONTRADICTED``.
    Raises ``ValueError`` if an item of the paper has no entry (see :func:`coverage`)."""
    out = []
    for item, e in entries_for(index):
        if e is None:
            raise ValueError(f"paper item {item.id} has no registry entry")
        res = {}
        for name in e.checks + e.literal:
            try:
                res[name] = run_check(name)
            except Exception as exc:  # noqa: BLE001 - a crashing check is a failed check
                res[name] = Outcome(False, None, None, f"{type(exc).__name__}: {exc}")
        good = all(res[n].ok for n in e.checks) and all(not res[n].ok for n in e.literal)
        verdict = {
            "verified": "verified",
            "erratum": "erratum confirmed",
            "restriction": "restriction confirmed",
            "definition": "definition",
            "not checkable": "not checkable",
        }[e.status]
        if e.status != "not checkable" and not good:
            verdict = "CONTRADICTED"
        out.append(EntryObservation(item, e, verdict, res))
    return out


def fmt_outcome(o: Outcome) -> str:
    """``pass``/``fail`` with the defect and its bound at one significant digit (stable across runs);
    for exact checks (no error) the check's own finding."""
    word = "pass" if o.ok else "fail"
    if o.error is None or not o.tolerance:
        return f"{word} ({_md_escape(o.detail)})" if o.detail and o.error is None else word
    return f"{word} (error {o.error:.0e}, bound {o.tolerance:.0e})"


def _md_escape(s: str) -> str:
    return s.replace("|", "∣")


def render_entries_markdown(index: PaperIndex, obs: list[EntryObservation]) -> str:
    """The coverage summary, one block per display and per sentence, and the errata found there."""
    cov = coverage(index)
    by_status = Counter(o.verdict for o in obs)
    lines = [
        "## Coverage",
        "",
        (
            f"* displayed formulas in the paper: {cov['displays']} ({cov['labelled_displays']} labelled, "
            f"{cov['displays'] - cov['labelled_displays']} unlabelled); mathematical sentences: "
            f"{cov['sentences']} (rule: oracles/paper_index.py)"
        ),
        (
            f"* items: {cov['items']}; with a registry entry: {cov['entries']}; missing: "
            f"{len(cov['missing'])}; misanchored: {len(cov['misanchored'])}; extra: {len(cov['extra'])}"
        ),
        "* observed: " + ", ".join(f"{k} {v}" for k, v in sorted(by_status.items())),
        "",
    ]

    def block(o: EntryObservation, head: str, body: list[str]) -> list[str]:
        e = o.entry
        out = [head, ""] + body
        out.append(f"* status: **{e.status}**; observed: {o.verdict}")
        out.append(f"* claim: {_md_escape(e.claim)}")
        if e.labels:
            out.append("* labels: " + ", ".join(e.labels))
        if e.corrected:
            out.append(f"* corrected: {_md_escape(e.corrected)}")
        if e.reason:
            out.append(f"* why: {_md_escape(e.reason)}")
        if e.checks or e.literal:
            chk = "; ".join(f"`{n}` {fmt_outcome(o.results[n])}" for n in e.checks)
            if e.literal:
                chk += "; printed form: " + "; ".join(
                    f"`{n}` {fmt_outcome(o.results[n])}" for n in e.literal
                )
            out.append(f"* checks: {chk}")
        if e.evidence:
            out.append(f"* evidence: {_md_escape(e.evidence)}")
        if e.attained:
            out.append(f"* bound attained: {_md_escape(e.attained)}")
        if e.needed:
            out.append(f"* hypothesis: {_md_escape(e.needed)}")
        return out + [""]

    lines += ["## Displayed formulas", ""]
    for o in obs:
        if hasattr(o.item, "latex"):
            d = o.item
            kind = ("labelled " + ", ".join(o.entry.labels)) if d.labels else "unlabelled"
            lines += block(o, f"### {d.id} ({kind}, {d.env})", ["```latex", d.latex, "```", ""])
    lines += ["## Mathematical sentences", ""]
    for o in obs:
        if not hasattr(o.item, "latex"):
            lines += block(o, f"### {o.item.id}", [f"> {o.item.text}", ""])
    lines += ["## Errata among the unlabelled formulas and the sentences", ""]
    for o in obs:
        e = o.entry
        if e.status == "erratum" and not (hasattr(o.item, "latex") and o.item.labels):
            lines.append(
                f"* **{o.item.id}** ({o.verdict}): {_md_escape(e.corrected)} (printed check: "
                f"{', '.join(e.literal)}; corrected: {', '.join(e.checks)})"
            )
    return "\n".join(lines) + "\n"
