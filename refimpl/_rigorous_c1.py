"""Uses of the C^1 enclosure (the flow map's Jacobian in balls, :func:`full_state_enclosure` with
``jacobian=True``): a proven Poisson-map defect and proven Casimir drifts.

* :func:`poisson_map_defect`: for the free body (no potential) the momenta evolve alone,
  ``pidot = -Phi^-1 S dK`` (vier11, ``Phi = 1 + S U``, ``S = pi.f - Theta``), a Hamiltonian system for the
  reduced bracket ``P(pi) = -Phi(pi)^-1 S(pi)`` (antisymmetric: ``(Phi^-1 S)^T = -S (1 + U S)^-1 =
  -Phi^-1 S`` by the push-through identity, ``S`` and ``U`` antisymmetric). Its flow map is a Poisson map,
  ``J P(pi0) J^T = P(pi(t))`` with ``J = d pi(t) / d pi0``. The ball of ``J P(pi0) J^T - P(pi(t))``, from
  the C^1 enclosure ``J`` and the enclosure of ``pi(t)``, contains 0 for the exact flow; its radius is a
  proven bound on the exact flow's defect as the enclosure sees it. For a map ``D`` (an integrator's
  Jacobian, from differences or its own balls) the same ball with ``D`` for ``J`` and its state for
  ``pi(t)`` is that integrator's defect, proven up to the accuracy of ``D``.
* :func:`casimir_drift`: ``C(pi_t) - C(pi0)`` in ball arithmetic for a Casimir given as a function on
  balls (a polynomial, e.g. ``|pi|^2`` on su(2)): with ``pi_t`` the enclosure of the exact flow it contains 0
  and its radius bounds the drift the enclosure allows; with an integrator's float64 answer it is that
  answer's drift, proven (every float is exact in the balls).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from flint import arb, arb_mat

from ._arb import Balls, exact_source, to_arb, workprec
from ._rigorous_state import full_state_enclosure

__all__ = ["casimir_drift", "poisson_map_defect", "reduced_poisson_tensor"]


def reduced_poisson_tensor(f, theta, upsilon, pi: list) -> arb_mat:
    """``P(pi) = -(1 + S U)^-1 S`` (``S = pi.f - Theta``) at the balls ``pi``, at the current precision;
    ``ZeroDivisionError`` where ``1 + S U`` is not provably invertible."""
    src = exact_source(f)
    n = src.shape[0]
    th = np.asarray(theta, dtype=object)
    U = arb_mat(n, n, [to_arb(v, "upsilon") for v in np.asarray(upsilon, dtype=object).flat])
    S = arb_mat(
        [
            [
                sum((pi[m] * to_arb(src[m, a, b], "f") for m in range(n)), arb(0))
                - to_arb(th[a, b], "theta")
                for b in range(n)
            ]
            for a in range(n)
        ]
    )
    eye = arb_mat([[1 if i == j else 0 for j in range(n)] for i in range(n)])
    return -((eye + S * U).inv() * S)


def poisson_map_defect(
    f, theta, upsilon, inertia, x0, pi0, t, *, prec_bits: int = 128, jacobian=None, pi_t=None
) -> Balls:
    """The ball matrix of ``J P(pi0) J^T - P(pi(t))`` for the free body (module docstring).

    Default: ``J`` and ``pi(t)`` from the C^1 enclosure of the exact flow (its balls contain 0; the radius
    is the proven defect bound). ``jacobian`` (an ``(n, n)`` float array) and ``pi_t`` (``(n,)``) replace
    them by an integrator's: its defect, in exact ball arithmetic on those floats."""

    n = np.asarray(pi0).shape[0]
    with workprec(prec_bits):
        if jacobian is None or pi_t is None:
            e = full_state_enclosure(
                f,
                theta,
                upsilon,
                inertia,
                None,
                x0,
                pi0,
                t,
                prec_bits=prec_bits,
                want_x=False,
                jacobian=True,
            )
            J = arb_mat([[e.jacobian.balls[i, j] for j in range(n)] for i in range(n)])
            p1 = list(e.pi.balls)
        if jacobian is not None:
            J = arb_mat([[arb(float(v)) for v in row] for row in np.asarray(jacobian, dtype=float)])
        if pi_t is not None:
            p1 = [arb(float(v)) for v in np.asarray(pi_t, dtype=float)]
        p0 = [to_arb(v, "pi0") for v in np.asarray(pi0, dtype=object)]
        D = J * reduced_poisson_tensor(f, theta, upsilon, p0) * J.transpose() - (
            reduced_poisson_tensor(f, theta, upsilon, p1)
        )
        return Balls(np.array(D.entries(), dtype=object).reshape(n, n), prec_bits)


def casimir_drift(casimir: Callable, pi0, pi_t, *, prec_bits: int = 128) -> arb:
    """``C(pi_t) - C(pi0)`` as a ball (module docstring): ``casimir`` maps a list of balls to a ball;
    ``pi_t`` is a :class:`Balls` (an enclosure) or a float array (an integrator's answer)."""
    with workprec(prec_bits):
        p0 = [to_arb(v, "pi0") for v in np.asarray(pi0, dtype=object)]
        p1 = (
            list(pi_t.balls)
            if isinstance(pi_t, Balls)
            else [arb(float(v)) for v in np.asarray(pi_t, dtype=float)]
        )
        return casimir(p1) - casimir(p0)
