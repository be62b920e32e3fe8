"""Checks of section un (R^N): the lifted affine change of frame (een2, erratum) and een3, the lifted
diffeomorphism of the unlabelled display."""

from __future__ import annotations

import re

import sympy as sp

from .common import Outcome

R = sp.Rational


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


def un_lift_diffeomorphism() -> Outcome:
    """Introduction, unlabelled display: for ``phi(x, y) = (x, y (1 + x^2))`` (inverse ``(x', y' / (1 + x'^2))``)
    the lift ``p'_k = p_l d(phi^-1)^l/dx'^k`` preserves ``dx^i ^ dp_i``; ``F'`` as printed pulls back
    to ``F``; ``B'`` as printed is the ``dp' ^ dp'`` coefficient of the pushed ``omega_B``; and
    (next sentence) ``B'`` depends on ``x'`` and the pushed ``omega_B`` acquires ``dx ^ dp`` terms.
    Exact (sympy) with ``F_12 = 1 + x y``, constant ``B^12 = 3/2``."""
    x, y, p, q = sp.symbols("x y p q")
    xp = sp.Matrix([x, y * (1 + x**2)])
    u_, v_ = sp.symbols("u v")
    inv = sp.Matrix([u_, v_ / (1 + u_**2)])  # phi^-1(x', y')
    # d(phi^-1)/dx' at x' = phi(x)
    Jinv = inv.jacobian([u_, v_]).subs({u_: xp[0], v_: xp[1]})
    pp = (sp.Matrix([[p, q]]) * Jinv).T  # p'_k = p_l d(phi^-1)^l / dx'^k
    z = [x, y, p, q]
    Zp = sp.Matrix.vstack(xp, pp)
    J = Zp.jacobian(z)

    def two_form(top_left, bottom_right, canon=True):
        M = sp.zeros(4, 4)
        M[:2, :2] = top_left
        M[2:, 2:] = bottom_right
        if canon:
            M[0, 2], M[1, 3], M[2, 0], M[3, 1] = 1, 1, -1, -1
        return M

    zero2 = sp.zeros(2, 2)
    canon_ok = sp.simplify(J.T * two_form(zero2, zero2) * J - two_form(zero2, zero2)).is_zero_matrix
    F = sp.Matrix([[0, 1 + x * y], [-(1 + x * y), 0]])
    Fp = Jinv.T * F * Jinv  # printed F'
    F_ok = sp.simplify(
        J.T * two_form(Fp, zero2, False) * J - two_form(F, zero2, False)
    ).is_zero_matrix
    B = sp.Matrix([[0, R(3, 2)], [R(-3, 2), 0]])
    Dphi = xp.jacobian([x, y])
    Bp = Dphi * B * Dphi.T  # printed B'
    # push omega_B forward: pulled-back 1/2 B' dp'^dp' must reproduce B in the dp^dp block
    pulled = sp.simplify(J.T * two_form(zero2, Bp, False) * J)
    B_block_ok = sp.simplify(pulled[2:, 2:] - B).is_zero_matrix
    mixed = (
        not sp.simplify(pulled[:2, 2:]).is_zero_matrix
        or not sp.simplify(pulled[:2, :2]).is_zero_matrix
    )
    depends_x = any(sp.diff(e, x) != 0 for e in Bp)
    ok = canon_ok and F_ok and B_block_ok and mixed and depends_x
    return Outcome(
        bool(ok),
        None,
        None,
        f"lift symplectic {canon_ok}; F' rule {F_ok}; B' = dp'dp' coefficient {B_block_ok}; "
        f"B' depends on x' {depends_x}; extra dx-terms {mixed}",
    )


CHECKS = {
    "een3_transformation": een3_transformation,
    "een2_printed": een2_printed,
    "een2_corrected": een2_corrected,
    "un_lift_diffeomorphism": un_lift_diffeomorphism,
}
