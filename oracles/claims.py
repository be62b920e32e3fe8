"""The registry of the paper's claims: one entry per numbered equation, with status and errata.

Each :class:`Claim` names the equation (the paper's ``\\label``; the second ``drie5`` is called
``drie12``), states what it claims, how it is checked (``symbolic``, ``numeric``, ``both``, or
``-``), where (oracle checks in :data:`oracles.claim_checks.PAPER_CHECKS`, run by
``tstarg claims``, and pytest tests), and a status:

``verified``
    the listed checks pass;
``erratum``
    the printed form is wrong; ``erratum`` states the correction and its evidence,
    ``literal`` names a check of the printed form that must FAIL and ``checks`` the
    checks of the corrected form that must PASS;
``not checkable``
    a definition or notation; ``reason`` says why.

:func:`evaluate` runs the checks and returns, per claim, the observed verdict; a claim
whose observation contradicts its status is reported as ``CONTRADICTED``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

__all__ = ["CLAIMS", "ERRATA", "LABELS", "Claim", "evaluate", "render_markdown"]


@dataclass(frozen=True)
class Claim:
    label: str
    section: str
    claim: str
    method: str
    status: str
    checks: tuple = ()
    tests: tuple = ()
    literal: tuple = ()
    erratum: str = ""
    reason: str = ""
    remark: str = ""


_DEF = "a definition (or notation): nothing to verify"
_T = "tests/"

CLAIMS: tuple[Claim, ...] = (
    # ----------------------------------------------------------------- un (R^N)
    Claim(
        "een1",
        "un",
        "omega_F = 1/2 F_ij dx^i^dx^j, omega_B = 1/2 B^kl dp_k^dp_l extend omega_0 on T*R^N",
        "-",
        "not checkable",
        reason=_DEF + " (recalled from the authors' earlier work)",
    ),
    Claim(
        "een2",
        "un",
        "lifted affine change of frame x' = A x + a, p' = p A^-1",
        "symbolic",
        "erratum",
        checks=("een2_corrected",),
        literal=("een2_printed",),
        tests=(_T + "test_claims.py::test_een2_index_erratum",),
        erratum="printed x'^i = A^i_j x^j + a^k; the translation must carry the free index: x'^i = A^i_j x^j + a^i "
        "(typographical; evidence: free-index check, printed term a^k has free index k != i)",
    ),
    Claim(
        "een3",
        "un",
        "Omega keeps its form with F' = A^-T F A^-1, B' = A B A^T",
        "symbolic",
        "verified",
        checks=("een3_transformation",),
        tests=(_T + "test_claims.py::test_een3_exact",),
        remark="typo 'dx{\\prime\\,^j}' in the source is cosmetic",
    ),
    # ----------------------------------------------------------------- deux
    Claim(
        "twee1",
        "deux",
        "left-invariant frame e^L_a = L^m_a(g,e) d/dg^m and coframe eps_L = L(g^-1,g) dg, "
        "with L^a_b(g,h) := d(gh)^a/dg^b",
        "numeric",
        "erratum",
        checks=("twee1_frame_corrected",),
        literal=("twee1_frame_printed",),
        tests=(
            _T + "test_claims.py::test_twee1_frame_erratum",
            _T + "test_frames.py::test_frames_match_first_principles",
        ),
        erratum="L^a_b(g,h) = d(gh)^a/dh^b (derivative in h, not g); then L(g,e) = phi1(-ad_x)^-1 and "
        "L(g^-1,g) = phi1(-ad_x). Evidence: d(gh)/dg at h=e is the identity, which differs from "
        "d/ds x(g exp(s e_b)) by O(1) (printed check fails), while d(gh)/dh matches to 45 digits",
    ),
    Claim(
        "twee2",
        "deux",
        "holonomic, body and space coordinates of T*G",
        "-",
        "not checkable",
        reason=_DEF,
    ),
    Claim(
        "twee3",
        "deux",
        "pi^R = K(g) pi^L = Ad(g^-1)^T pi^L",
        "numeric",
        "verified",
        checks=("twee3_coadjoint",),
        tests=(_T + "test_claims.py::test_paper_checks_pass",),
    ),
    Claim(
        "twee4",
        "deux",
        "left-invariant coframe on T*G: (L(g^-1,g) dg, dpi)",
        "numeric",
        "erratum",
        checks=("twee1_frame_corrected",),
        literal=("twee1_frame_printed",),
        erratum="inherits the twee1 erratum: with L differentiated w.r.t. h, L(g^-1,g) = phi1(-ad_x) and the "
        "coframe is dual to the frame of twee5 (checked: L(g^-1,g) L(g,e) = 1)",
    ),
    Claim(
        "twee5",
        "deux",
        "dual frame (L(g,e) d/dg, d/dpi)",
        "numeric",
        "erratum",
        checks=("twee1_frame_corrected",),
        literal=("twee1_frame_printed",),
        erratum="inherits the twee1 erratum (L(g,e) = d(gh)/dh at h = e = phi1(-ad_x)^-1)",
    ),
    Claim(
        "twee6",
        "deux",
        "theta_0 = pi_m eps_L^m, omega_0 = -d theta_0 = eps^m^dpi_m + 1/2 pi_m f^m_ab eps^a^eps^b",
        "numeric",
        "verified",
        checks=("liouville_forms",),
    ),
    Claim(
        "twee7",
        "deux",
        "Hamiltonian vector field of omega_0: X^m = dA/dpi_m, X_a = -<dA|e_a> - pi_m f^m_ab dA/dpi_b",
        "symbolic",
        "verified",
        checks=("quatre_identities",),
        tests=(_T + "test_poisson_routes.py::test_upsilon_zero_reduces_to_twee9_drie3",),
        remark="special case Theta = Upsilon = 0 of vier8 (exact check of vier8 for random models)",
    ),
    Claim(
        "twee8",
        "deux",
        "{A,B}_0 = <dA|e_a> dB/dpi_a - dA/dpi_a <dB|e_a> - dA/dpi_a pi_m f^m_ab dB/dpi_b",
        "both",
        "verified",
        checks=("quatre_identities",),
        tests=(_T + "test_poisson_routes.py::test_upsilon_zero_reduces_to_twee9_drie3",),
    ),
    Claim(
        "twee9",
        "deux",
        "{g,g}=0, {g^a,pi_n}=L^a_n(g,e), {pi_m,pi_n} = -pi_k f^k_mn",
        "both",
        "verified",
        checks=("quatre_identities",),
        tests=(
            _T + "test_poisson_routes.py::test_upsilon_zero_reduces_to_twee9_drie3",
            _T + "test_qutip_spin.py::test_commutators_match_lie_poisson",
        ),
    ),
    Claim("twee10", "deux", "K = 1/2 I^ab pi_a pi_b", "-", "not checkable", reason=_DEF),
    Claim(
        "twee11",
        "deux",
        "L(g^-1,g) dg/dt = dK/dpi",
        "numeric",
        "verified",
        checks=("euler_equations",),
        tests=(_T + "test_vector_field.py::test_reduces_to_twee12_and_drie5",),
    ),
    Claim(
        "twee12",
        "deux",
        "dpi_m/dt = -dV/dg^a L^a_m(g,e) + dK/dpi_n pi_a f^a_nm",
        "numeric",
        "verified",
        checks=("euler_equations", "euler_equations_general"),
        tests=(_T + "test_vector_field.py::test_reduces_to_twee12_and_drie5",),
    ),
    Claim(
        "twee13",
        "deux",
        "Omega_L = L(g^-1,g) dg/dt = I^-1 pi",
        "numeric",
        "verified",
        checks=("euler_equations",),
    ),
    Claim(
        "twee14",
        "deux",
        "dpi_m/dt + pi_k f^k_mn Omega^n = -<dV|e_m>",
        "numeric",
        "verified",
        checks=("euler_equations", "euler_equations_general"),
        tests=(_T + "test_closed_forms.py::test_elliptic_solution_satisfies_reference_field",),
    ),
    Claim(
        "twee15",
        "deux",
        "V(g) = -(gamma | Ad(g) L) = -(K(g^-1) gamma | L)",
        "numeric",
        "verified",
        checks=("twee16_gravity_gradient",),
        remark="K(g^-1) = Ad(g)^T; V = -(Gamma|L)",
    ),
    Claim(
        "twee16",
        "deux",
        "<dV|e^L_m> = -(Gamma | ad(e_m) L), Gamma = K(g^-1) gamma",
        "numeric",
        "verified",
        checks=("twee16_gravity_gradient",),
    ),
    Claim(
        "twee17",
        "deux",
        "dGamma_m/dt = (Gamma | ad(e_m) Omega) = Gamma_a f^a_mb Omega^b",
        "numeric",
        "erratum",
        checks=("twee17_corrected",),
        literal=("twee17_printed",),
        tests=(
            _T + "test_vector_field.py::test_euler_poisson_sign_twee17_erratum",
            _T + "test_claims.py::test_twee17_erratum",
        ),
        erratum="sign: dGamma_m/dt = -(Gamma | ad(e_m) Omega) = Omega^b f^a_bm Gamma_a = (ad_Omega^T Gamma)_m "
        "(so(3): dGamma/dt = Gamma x Omega). Evidence: chain rule d/ds Ad(g exp(s Omega))^T gamma "
        "agrees with the corrected form to 45 digits and differs from the printed one by O(1)",
    ),
    Claim(
        "twee18",
        "deux",
        "dpi_m/dt + pi_a f^a_mb Omega^b = Gamma_a f^a_mb L^b (so(3): pi x Omega + L x Gamma)",
        "numeric",
        "verified",
        checks=("euler_equations", "euler_equations_general"),
        tests=(_T + "test_closed_forms.py::test_heavy_top_integrals_conserved",),
    ),
    # ----------------------------------------------------------------- trois
    Claim(
        "drie1",
        "trois",
        "omega_I = omega_0 - Theta_L = eps^dpi + 1/2 (pi.f - Theta) eps^eps",
        "numeric",
        "verified",
        checks=("liouville_forms", "vier2_closed"),
    ),
    Claim(
        "drie2",
        "trois",
        "{A,B}_I with -(pi.f - Theta) in the momentum block",
        "both",
        "verified",
        checks=("quatre_identities",),
        tests=(_T + "test_poisson_routes.py::test_upsilon_zero_reduces_to_twee9_drie3",),
    ),
    Claim(
        "drie3",
        "trois",
        "{pi_m,pi_n}_I = -(pi_k f^k_mn - Theta_mn)",
        "both",
        "verified",
        checks=("quatre_identities",),
        tests=(
            _T + "test_poisson_routes.py::test_upsilon_zero_reduces_to_twee9_drie3",
            _T + "test_qutip_spin.py::test_commutators_match_lie_poisson",
        ),
    ),
    Claim(
        "drie4",
        "trois",
        "Omega = dK/dpi = I^-1 pi",
        "numeric",
        "verified",
        checks=("euler_equations",),
    ),
    Claim(
        "drie5",
        "trois",
        "dpi_m/dt = -<dV|e_m> + dK/dpi_a (pi_k f^k_am - Theta_am)",
        "numeric",
        "verified",
        checks=("euler_equations", "euler_equations_general"),
        tests=(_T + "test_vector_field.py::test_reduces_to_twee12_and_drie5",),
    ),
    Claim(
        "drie6",
        "trois",
        "dpi_m/dt + pi_k f^k_ma Omega^a = -<dV|e_m> - Omega^a Theta_am",
        "numeric",
        "verified",
        checks=("euler_equations", "euler_equations_general"),
    ),
    Claim(
        "drie7",
        "trois",
        "theta_I = pi'_m eps^m, pi' = pi + xi (semisimple, Theta = -xi.f)",
        "numeric",
        "verified",
        checks=("liouville_forms",),
    ),
    Claim(
        "drie8",
        "trois",
        "omega_I = -d theta_I = eps^dpi' + 1/2 pi'.f eps^eps",
        "numeric",
        "verified",
        checks=("liouville_forms",),
    ),
    Claim(
        "drie9",
        "trois",
        "(g, p' = p + xi_b L^b(g^-1,g)) are Darboux coordinates of omega_I",
        "numeric",
        "verified",
        checks=("drie9_darboux",),
        remark="uses L(g^-1,g) = phi1(-ad_x), i.e. the twee1 correction; '(g^{-1};g)' semicolon is a typo",
    ),
    Claim(
        "drie10",
        "trois",
        "H' = 1/2 I^mn (pi'_m - xi_m)(pi'_n - xi_n) + V",
        "-",
        "not checkable",
        reason=_DEF + " (H rewritten in pi'; its consequences drie11/drie12 are checked)",
    ),
    Claim(
        "drie11",
        "trois",
        "L(g^-1,g) dg/dt = dK'/dpi' = I^-1 (pi' - xi)",
        "numeric",
        "verified",
        checks=("euler_equations",),
    ),
    Claim(
        "drie12",
        "trois",
        "dpi'_m/dt = -<dV|e_m> + dK'/dpi'_a pi'_k f^k_am (printed with the label drie5)",
        "numeric",
        "erratum",
        checks=("labels_unique_corrected", "euler_equations"),
        literal=("labels_unique_printed",),
        tests=(_T + "test_claims.py::test_registry_covers_every_label",),
        erratum="label: the paper gives \\label{drie5} twice; the second one (the dpi'/dt equation after drie11) "
        "is called drie12 here. Its content is verified (euler_equations, drie12 form).",
    ),
    # ----------------------------------------------------------------- quatre
    Claim(
        "vier1",
        "quatre",
        "Upsilon^L = 1/2 Upsilon^mn dpi_m ^ dpi_n",
        "-",
        "not checkable",
        reason=_DEF,
    ),
    Claim(
        "vier2",
        "quatre",
        "omega_L = omega_0 - Theta_L + Upsilon^L is closed",
        "numeric",
        "verified",
        checks=("vier2_closed",),
        remark="closedness checked as the Jacobi identity of its Poisson tensor",
    ),
    Claim(
        "vier3",
        "quatre",
        "omega_L = 1/2 theta^T ^ [[S, 1], [-1, Upsilon]] theta, S = pi.f - Theta",
        "both",
        "verified",
        checks=("quatre_identities", "liouville_forms"),
        tests=(_T + "test_poisson_routes.py::test_tensor_inverts_omega",),
    ),
    Claim("vier4", "quatre", "i_X omega_L = dA defines X_A", "-", "not checkable", reason=_DEF),
    Claim(
        "vier5",
        "quatre",
        "X^a Phi_a^n = dA^n + dA_m U^mn, X_m Psi^m_b = -dA_b + dA^a S_ab",
        "symbolic",
        "verified",
        checks=("quatre_identities",),
    ),
    Claim(
        "vier6",
        "quatre",
        "Phi = 1 + S U, Psi = 1 + U S mutually transposed; Phi S = S Psi, U Phi = Psi U antisymmetric",
        "symbolic",
        "verified",
        checks=("quatre_identities",),
        tests=(_T + "test_claims.py::test_quatre_identities",),
    ),
    Claim(
        "vier7",
        "quatre",
        "solvable iff Delta = det Phi = det Psi != 0; U Phi^-1, Phi^-1 S antisymmetric",
        "symbolic",
        "verified",
        checks=("quatre_identities",),
    ),
    Claim(
        "vier8",
        "quatre",
        "X^a = Psi^-1 (dA^ - U dA_) = (dA^ + dA_ U) Phi^-1, X_m = Phi^-1(-dA_ - S dA^) = (...) Psi^-1",
        "symbolic",
        "verified",
        checks=("quatre_identities",),
    ),
    Claim(
        "vier9",
        "quatre",
        "basic brackets {g,g} = -L L U Phi^-1, {g,pi} = L Psi^-1, {pi,pi} = -S Psi^-1",
        "both",
        "verified",
        checks=("quatre_identities",),
        tests=(_T + "test_poisson_routes.py::test_closed_formulas_match_first_principles",),
    ),
    Claim(
        "vier10",
        "quatre",
        "Omega = (dK + dV U) Phi^-1",
        "both",
        "verified",
        checks=("quatre_identities", "cinq_nondegenerate"),
        tests=(_T + "test_vector_field.py::test_closed_equals_first_principles",),
    ),
    Claim(
        "vier11",
        "quatre",
        "dpi/dt = (-dV + dK S) Psi^-1",
        "both",
        "verified",
        checks=("quatre_identities", "cinq_nondegenerate"),
        tests=(_T + "test_vector_field.py::test_closed_equals_first_principles",),
    ),
    Claim(
        "vier12",
        "quatre",
        "Pi_1 = {Delta = 0}; Delta a polynomial in pi of degree <= N",
        "symbolic",
        "verified",
        checks=("vier12_degree",),
    ),
    Claim("vier13", "quatre", "M_0' = G x (g* minus Pi_1)", "-", "not checkable", reason=_DEF),
    Claim(
        "vier14", "quatre", "M_1 = G x Pi_1 with embedding j_1", "-", "not checkable", reason=_DEF
    ),
    # ----------------------------------------------------------------- cinq
    Claim(
        "vijf1",
        "cinq",
        "su(2): S_ab = pi'_k eps_kab, Upsilon^mn = tau_l eps_lmn; Phi = C1 1 + tau pi'^T, "
        "Psi = C1 1 + pi' tau^T, Delta = C1^2, C1 = 1 - pi'.tau; printed inverses",
        "symbolic",
        "verified",
        checks=("cinq_nondegenerate",),
        tests=(_T + "test_su2_symbolic.py::test_nondegenerate_identities",),
    ),
    Claim(
        "vijf2",
        "cinq",
        "X^a C1 = H^a - pi'^a (tau.H^) - eps_amn H_m tau_n",
        "symbolic",
        "verified",
        checks=("cinq_nondegenerate",),
        tests=(_T + "test_su2_symbolic.py::test_nondegenerate_identities",),
    ),
    Claim(
        "vijf3",
        "cinq",
        "X_m C1 = -H_m + tau_m (pi'.H_) - eps_mab H^a pi'_b",
        "symbolic",
        "verified",
        checks=("cinq_nondegenerate",),
    ),
    Claim(
        "vijf4",
        "cinq",
        "equations of motion with the explicit Phi^-1, Psi^-1",
        "both",
        "verified",
        checks=("cinq_nondegenerate",),
        tests=(_T + "test_su2_symbolic.py::test_vijf4_matches_reference",),
    ),
    Claim(
        "vijf5",
        "cinq",
        "V = 0: Omega = dK Phi^-1, dpi_m/dt = Omega^a pi'_b eps_bam",
        "both",
        "verified",
        checks=("cinq_nondegenerate",),
        tests=(_T + "test_su2_symbolic.py::test_vijf4_matches_reference",),
    ),
    Claim(
        "vijf6",
        "cinq",
        "embedding j_1: pi_3 = 1/tau - xi_3 (tau = (0,0,tau))",
        "symbolic",
        "verified",
        checks=("cinq_degenerate",),
    ),
    Claim(
        "vijf7",
        "cinq",
        "push-forward j_1*: X_3 = 0",
        "symbolic",
        "verified",
        checks=("cinq_degenerate",),
    ),
    Claim("vijf8", "cinq", "pull-back j_1^* on forms", "-", "not checkable", reason=_DEF),
    Claim(
        "vijf9",
        "cinq",
        "pull-back of omega_L to the 5-manifold M_1",
        "symbolic",
        "verified",
        checks=("cinq_degenerate",),
        remark="= W with the dpi_3 row and column deleted; rank 4",
    ),
    Claim(
        "vijf10",
        "cinq",
        "the 6x6 matrix of omega_L restricted to M_1",
        "symbolic",
        "verified",
        checks=("cinq_degenerate",),
        tests=(_T + "test_su2_symbolic.py::test_degenerate_identities",),
    ),
    Claim(
        "vijf11",
        "cinq",
        "i_X omega_L|1 = dH o j_1 and its six component equations",
        "symbolic",
        "verified",
        checks=("cinq_degenerate",),
    ),
    Claim(
        "vijf12",
        "cinq",
        "null vectors Z^1, Z^2 of omega_L|1 (kernel exactly 2-dimensional)",
        "symbolic",
        "verified",
        checks=("cinq_degenerate",),
    ),
    Claim(
        "vijf13",
        "cinq",
        "consistency <dH|Z^a> = 0 <=> C21 = C22 = 0",
        "symbolic",
        "verified",
        checks=("cinq_degenerate", "cinq_gnh"),
        remark="<dH|Z^a> = -C2a (sign immaterial for a constraint)",
    ),
    Claim(
        "vijf14",
        "cinq",
        "particular solution X_P on M_2 with X_3 = C23",
        "symbolic",
        "verified",
        checks=("cinq_degenerate",),
    ),
    Claim(
        "vijf15",
        "cinq",
        "general solution X_G = X_P + zeta_1 Z^1 + zeta_2 Z^2 on M_2",
        "symbolic",
        "verified",
        checks=("cinq_degenerate", "cinq_gnh"),
        tests=(_T + "test_gnh.py::test_worked_examples",),
    ),
    Claim(
        "vijf16",
        "cinq",
        "tangency <dC1|X_G> = <dC21|X_G> = <dC22|X_G> = 0 decides zeta or a tertiary set",
        "symbolic",
        "verified",
        checks=("cinq_degenerate", "cinq_gnh"),
        tests=(_T + "test_gnh.py::test_worked_examples",),
    ),
    # ----------------------------------------------------------------- sept
    Claim(
        "zeven1",
        "sept",
        "delta_2 Theta = -Theta_kc f^k_ab + Theta_kb f^k_ac - Theta_ka f^k_bc = 0",
        "symbolic",
        "verified",
        checks=("zeven1_jacobi",),
        tests=(_T + "test_claims.py::test_zeven1_is_jacobi",),
        remark="same solution space as the Jacobi identity of drie3 (closedness of Theta_L)",
    ),
    Claim(
        "zeven2",
        "sept",
        "Theta_L = 1/2 Theta_ab eps_L^a ^ eps_L^b is closed and left-invariant",
        "symbolic",
        "verified",
        checks=("zeven1_jacobi",),
    ),
    Claim(
        "zeven3",
        "sept",
        "semisimple: Theta = -xi_m f^m_ab (Whitehead)",
        "symbolic",
        "verified",
        checks=("zeven3_whitehead",),
        tests=(_T + "test_cohomology.py::test_whitehead_xi_recovered",),
    ),
)

LABELS = tuple(c.label for c in CLAIMS)
ERRATA = tuple(c for c in CLAIMS if c.status == "erratum")


@dataclass
class Observation:
    claim: Claim
    verdict: str
    results: dict = field(default_factory=dict)
    seconds: float = 0.0


def evaluate(claims=CLAIMS, *, cache: dict | None = None) -> list[Observation]:
    """Run every check named by the claims (each once) and compare with the recorded status.

    verified: all ``checks`` pass -> ``verified`` else ``CONTRADICTED``; erratum: all ``checks`` pass
    and all ``literal`` checks fail -> ``erratum confirmed`` else ``CONTRADICTED``; not checkable ->
    ``not checkable``.
    """
    from .claim_checks import run_paper_check

    cache = {} if cache is None else cache
    out = []
    for c in claims:
        t0 = time.perf_counter()
        res = {}
        for name in c.checks + c.literal:
            if name not in cache:
                try:
                    cache[name] = run_paper_check(name)
                except Exception as exc:  # noqa: BLE001 - a crashing check is a failed check
                    from .claim_checks import Outcome

                    cache[name] = Outcome(False, None, None, f"{type(exc).__name__}: {exc}")
            res[name] = cache[name]
        if c.status == "not checkable":
            verdict = "not checkable"
        elif c.status == "verified":
            verdict = "verified" if all(res[n].ok for n in c.checks) else "CONTRADICTED"
        else:
            good = all(res[n].ok for n in c.checks) and all(not res[n].ok for n in c.literal)
            verdict = "erratum confirmed" if good else "CONTRADICTED"
        out.append(Observation(c, verdict, res, time.perf_counter() - t0))
    return out


def _fmt(o) -> str:
    # one significant digit: the report must not change from run to run
    word = "pass" if o.ok else "fail"
    if o.error is None or not o.tolerance:
        return word
    return f"{word} ({o.error:.0e}/{o.tolerance:.0e})"


def render_markdown(obs: list[Observation]) -> str:
    lines = [
        "# The paper's claims",
        "",
        (
            "One row per numbered equation (the paper's `\\label`; the second `drie5` is `drie12`). "
            "Status: `verified`, `erratum` (printed form fails its check, corrected form passes), "
            "`not checkable` (definitions). Checks are in `oracles/claim_checks.py` "
            "(run by `tstarg claims`); error/tolerance shown where numeric, to one digit. "
            "Every displayed formula (labelled or not) and every mathematical sentence follows "
            "below the errata (`oracles/claims_unlabelled.py`)."
        ),
        "",
        "| label | section | claim | method | status | observed | checks | tests |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for o in obs:
        c = o.claim
        checks = "; ".join(f"`{n}` {_fmt(o.results[n])}" for n in c.checks)
        if c.literal:
            checks += "; printed: " + "; ".join(f"`{n}` {_fmt(o.results[n])}" for n in c.literal)
        tests = "<br>".join(f"`{t}`" for t in c.tests)
        extra = c.reason or c.remark
        lines.append(
            f"| {c.label} | {c.section} | {c.claim.replace('|', '∣')}{(' — ' + extra.replace('|', '∣')) if extra else ''} "
            f"| {c.method} | {c.status} | {o.verdict} | {checks or '-'} | {tests or '-'} |"
        )
    lines += ["", "## Errata", ""]
    for c in ERRATA:
        lines.append(
            f"* **{c.label}**: {c.erratum} (printed check: {', '.join(c.literal)}; corrected: {', '.join(c.checks)})"
        )
    return "\n".join(lines) + "\n"
