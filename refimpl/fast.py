"""The fast implementation: numpy float64, batched over any leading axes, with error bounds.

Same mathematics as :mod:`refimpl.reference` (docs/conventions.md), computed
independently:

* **su(2) closed forms** (``f = eps`` exactly): ``L(g,e) = 1 + K/2 + c K^2``
  with ``K = ad_x = [x]_x``, ``c = (1 - (t/2) cot(t/2)) / t^2``, ``t = |x|``;
  ``Phi = C1 + tau pi'^T``, ``Psi^-1 = (1 - pi' tau^T)/C1`` with
  ``C1 = 1 - pi'.tau``, ``pi' = pi + xi`` (section cinq), so that
  ``P_xp = L Psi^-1``, ``P_pp = [pi']_x / C1`` and
  ``P_xx = det(L) [phi1(K) tau]_x / C1`` (from ``M [v]_x M^T = det M [M^-T v]_x``).
  Evaluated components-first in cache-sized chunks.
* **any algebra**: batched matrices. ``L(g,e) = B(ad_x)`` with
  ``B(z) = z/(1-e^-z) = 1 + z/2 + sum_k B_2k z^2k/(2k)!`` summed by
  Paterson-Stockmeyer in ``ad_x^2`` when ``||ad_x||_F < pi`` (no inverse
  needed; the tail bound ``3.3 r^(2K+2)/(1-r^2)``, ``r = ||ad_x||/2pi``, sets
  the number of terms), otherwise ``phi1(-ad_x)`` by scaling and squaring and
  a solve. Then ``P_xp = L Psi^-1``, ``P_pp = -S Psi^-1``,
  ``P_xx = -P_xp U L^T`` (vier9; ``Psi^-1 U = U Phi^-1``).
* **work skipped**: with ``Upsilon = 0`` no Phi is formed or solved
  (``Phi = 1``, ``cond = 1``, ``P_xx = 0``); with ``Theta = 0`` nothing of
  Theta is touched; with ``potential = None`` no ``Ad(g)`` is computed.

Every batch result carries, per point:

``cond_phi``
    ``||Phi||_F ||Phi^-1||_F / n`` (1 at Phi = 1; within a factor n of the
    2-norm condition number).
``cond_data``
    ``||Phi^-1||_F (1 + ||S||_F ||Upsilon||_F) / sqrt(n)``: the sensitivity of
    Phi^-1 to rounding in its data ``S``, ``Upsilon``. It can exceed
    ``cond_phi`` by any factor: on a 2-dimensional algebra ``Phi = (1 - us) 1``
    has ``cond_phi = 1`` however close Delta is to 0, while the cancellation
    in ``1 - us`` costs ``1/|1 - us|`` of relative accuracy.
``error_bound``
    a bound on ``max_ij |P_fast - P_exact|``:
    ``C_P * n * eps * max(cond_phi, cond_data) * frame_cond * scale`` with ``C_P = 16``,
    ``frame_cond = 1/(1 - |x|/2pi)`` for su(2) (``1/(1-r)`` in general) and
    ``scale = max_ij |P|``. The generic path adds the rounding of *forming* the
    data, ``C_P n eps frame_cond (d_S + ||sum_a |x^a||f_a| ||_F max|P|)``, with
    ``d_S = ||sum_m |pi_m||f^m| + |Theta| ||_F`` propagated to first order through
    vier9 (``dP = G dS G^T``, ``G = -[[L U Phi^-1], [Phi^-1]]``); these summand
    magnitudes exceed ``||S||``, ``||ad_x||`` by any factor when the sums cancel
    (an ill-conditioned basis, found by ``tstarg stress``: the error there was up
    to 1.3e7 times the bound without these terms). The vector field adds, in the
    same way, ``cond(I)`` of forming ``I^-1 pi``. Tested against the mpmath
    reference across conditioning regimes and by ``tstarg stress``.
``degenerate``
    ``True`` where Phi is singular to working precision
    (``cond_phi * n * eps >= 1/16`` or C1 = 0): the point lies on the
    degenerate set Pi_1 (vier12) to float64 accuracy. ``P`` is NaN there;
    such points are never dropped. The protocol methods raise
    :class:`DegeneratePointError` (a ``ValueError``) naming them.
``outside_chart``
    ``True`` where ``x`` lies at or past the edge of the chart of exponential
    coordinates, ``rho(x) = max |Im eigenvalue of ad_x| >= 2 pi`` to float64
    accuracy (su(2): ``|x| >= 2 pi``; twee1: ``phi1(-ad_x)`` is singular at
    ``2 pi i k``), including ``x`` whose ``ad_x`` overflows. ``P`` is NaN and
    ``error_bound`` inf there (the bound is valid only inside the chart); such
    points are never dropped. The protocol methods raise :class:`ChartError`.
"""

from __future__ import annotations

from ._errors import DegeneratePointError
from ._fast_kernels import C_P, FastCore, FieldBatch, PoissonBatch
from ._protocol import Implementation
from .flows import fast_flow
from .flows._fast import flow_one

__all__ = ["Fast", "implementation", "PoissonBatch", "FieldBatch", "DegeneratePointError", "C_P"]


class Fast(FastCore, Implementation):
    """The fast float64 implementation of the whole protocol (docs/design.md).

    The batched kernels (:meth:`poisson_batch`, :meth:`vector_field_batch`, and the protocol's
    ``poisson_tensor`` and ``hamiltonian_vector_field``) come from
    :class:`refimpl._fast_kernels.FastCore`; protocol method 3 adds the batched flow.
    """

    flow_tolerance = 1e-10  # the default tolerance of refimpl.flows.fast_flow (worst trajectory)
    domain = {"negative_t": True}  # flows run backwards too: certified for t < 0, a refusal fails

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):
        """Protocol method 3: ``(x, pi)`` at time ``t``, batched (:func:`refimpl.flows.fast_flow`; one
        trajectory first through its protocol call, :func:`refimpl.flows._fast.flow_one`, the same)."""
        tol = self.flow_tolerance
        one = flow_one(f, theta, upsilon, inertia, potential, x0, pi0, t, tol)
        if one is not None:
            return one
        return fast_flow(f, theta, upsilon, inertia, potential, x0, pi0, t, tol=tol)


implementation = Fast()
