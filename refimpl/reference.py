"""The mpmath reference implementation: any precision, one point at a time, written to be read.

Mathematics (docs/conventions.md, the paper's labels):

* ``g = exp(x^a e_a)``; ``A(x) = phi1(-ad_x)`` with ``phi1(M) = (e^M - 1)/M``
  is the paper's ``L(g^-1, g)`` (coframe ``eps_L = A dx``) and
  ``L(g, e) = A^-1`` (frame ``e^L_a = (A^-1)^m_a d/dx^m``), twee1.
* ``S = pi_m f^m - Theta`` (vier3), ``Phi = 1 + S Upsilon``,
  ``Psi = 1 + Upsilon S = Phi^T``, ``Delta = det Phi`` (vier6, vier7).
* ``omega_L = 1/2 theta^T ^ W theta``, ``W = [[S, 1], [-1, Upsilon]]`` in the
  frame ``theta = (eps_L, dpi)`` (vier3); ``{A, B} = -dA . W^-1 . dB``.

Two independent routes to the Poisson tensor:

``route="closed"``
    the paper's closed formulas (vier9): body blocks
    ``[[-Upsilon Phi^-1, Psi^-1], [-Phi^-1, -S Psi^-1]]`` from an ``n x n``
    inverse of Phi, the frame ``A`` summed as a Taylor series, and the
    holonomic tensor ``T P_body T^T`` with ``T = diag(A^-1, 1)``.
``route="first_principles"``
    build the ``2n x 2n`` matrix of ``omega_L`` in holonomic coordinates
    ``Omega_hol = diag(A, 1)^T W diag(A, 1)`` with ``A`` taken from the
    block exponential ``expm([[-ad_x, 1], [0, 0]]) = [[e^-ad, phi1(-ad)], [0, 1]]``
    (Van Loan), and invert it: ``P = -Omega_hol^-1``.

Vector fields (vier10, vier11) likewise: closed formulas with the gravity
gradient ``<dV|e^L_b> = -Gamma_m f^m_bc L^c`` (twee16), or first principles
``zdot = P grad H`` with ``d V/d x`` differentiated numerically (mpmath.diff)
from ``V(x) = -gamma . exp(ad_x) L`` (twee15).

Precision hygiene: every public method runs inside ``mpmath.workdps`` at the
instance's ``dps`` plus guard digits and never changes global precision.
"""

from __future__ import annotations

from ._errors import DegeneratePointError
from ._flow_reference import reference_flow
from ._protocol import Implementation
from ._reference_core import GUARD_DIGITS, ReferenceCore

__all__ = ["Reference", "implementation", "DegeneratePointError", "GUARD_DIGITS"]


class Reference(ReferenceCore, Implementation):
    """The reference implementation of the whole protocol at ``dps`` digits (docs/design.md).

    Brackets and vector fields come from :class:`refimpl._reference_core.ReferenceCore`;
    protocol method 3 adds the reference flow.
    """

    domain = {"negative_t": True}  # flows run backwards too: certified for t < 0, a refusal fails

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):
        """Protocol method 3: ``(x, pi)`` at time ``t`` at this instance's precision
        (:func:`refimpl.flows.reference_flow`)."""
        return reference_flow(f, theta, upsilon, inertia, potential, x0, pi0, t, dps=self.dps)


implementation = Reference(dps=50)
