"""Flows of ``H = K(pi) + V(g)`` under omega_L: reference trajectories, fast integrators, invariants.

The flows wing. This package's face re-exports; the pieces:

* :mod:`refimpl.flows.base` -- the integrator interface (:class:`Integrator`, :class:`FixedStep`,
  :class:`Adaptive`) and the typed :class:`FlowResult`;
* :mod:`refimpl.flows.integrators` -- one file per integrator class (RK, scalar RK, Gauss-Legendre,
  fixed and adaptive Taylor, rational Taylor, splitting), found by :mod:`refimpl.flows.registry`
  (:data:`METHODS`, :func:`method`, :func:`choose`);
* :mod:`refimpl.flows.step_doubling` -- the wrapper that makes a fixed-step method meet a tolerance;
  the two-run control of the compiled Taylor flows is :mod:`refimpl._flow_compiled`;
* :mod:`refimpl.flows._fast` -- the protocol flow :func:`fast_flow` (validate, choose, integrate) and
  :func:`fast_trajectory`;
* beside them: the reference flow :mod:`refimpl._flow_reference` (mpmath, any precision), the
  invariants :mod:`refimpl._invariants`, the scenes :mod:`refimpl.scenes`.

Adding an integrator: one module in ``refimpl/flows/integrators/`` (see :mod:`refimpl.flows.base`
for the contract) and its order test.

Protocol method 3 (docs/design.md), with the signature
``flow(f, theta, upsilon, inertia, potential, x0, pi0, t) -> (x, pi)``:

* :func:`reference_flow` (``dps=50``): the full state of vier10/vier11 by
  Gragg-Bulirsch-Stoer extrapolation at ``dps + 15`` digits, re-basing
  ``g = g_ref exp(x)`` on long flows;
* :func:`fast_flow`: float64, batched over the leading axes of ``x0``, ``pi0``;
  the number of steps is doubled until two runs agree to ``tol`` on every
  trajectory (worst trajectory, not an average).

Body systems only (no configuration; ``integrate(..., system="body")``
or ``fast_trajectory(..., system="body")``): ``dop853-scalar`` and the
Taylor-series methods ``taylor12/16/20/24`` (:mod:`refimpl._taylor`: Cauchy-
product recurrences for the quadratic field of ``Upsilon = 0``): the fastest
fixed-step methods here for one trajectory; for batches on par with the batched
``dop853`` on an asymmetric top and several times faster when a component is
constant (a symmetric top's ``pi_3``), see tests/benchmarks/test_bench_flows.py.

Scenes (:func:`load_scene`, :func:`plan`, :func:`run_scene`): see :mod:`refimpl.scenes`.

Invariants (:func:`energy`, :func:`casimirs`, :func:`momentum_map`):

* energy ``H = 1/2 pi.I^-1 pi - Gamma.L`` (twee10, twee15);
* Casimirs of the reduced Lie-Poisson brackets: for su(2) ``|pi'|^2`` with
  ``pi' = pi + xi`` (drie7; Upsilon = 0); for Euler-Poisson on so(3)/su(2)
  ``|Gamma|^2`` and ``pi'.Gamma``;
* the momentum map of the left action ``h.(g, pi) = (hg, pi)`` when ``V = 0``.
  Its generator is the right-invariant field ``X_zeta(g) = zeta g``, with body
  components ``Ad(g^-1) zeta`` and no ``pi`` component, so ``Upsilon`` does not
  enter. ``i_X omega_0 = d(pi.Ad(g^-1) zeta)`` since ``omega_0 = -d(pi eps_L)``
  and ``L_X (pi eps_L) = 0``. The closed left-invariant form ``Theta_L`` gives
  ``i_X Theta_L = d phi_zeta``; integrating along ``s -> exp(s x)``, where
  ``eps_L = x ds`` and ``Ad(exp(-s x)) = exp(-s ad_x)``,
  ``phi_zeta(x) = int_0^1 Theta(exp(-s ad_x) zeta, x) ds = Theta(A zeta, x)``
  with ``A = phi1(-ad_x)``. Hence, for ``omega_I = omega_0 - Theta_L`` (drie1),
  ``J(g, pi) = K(g) pi - A(x)^T Theta x`` with ``K(g) = Ad(g^-1)^T`` (twee3);
  across re-basings the path integral adds ``K(g_ref) A(x)^T Theta x`` per
  segment. For a coboundary ``Theta = -xi.f`` (zeven3),
  ``ad_x A = 1 - e^-ad_x`` gives ``A^T Theta x = xi - K(g) xi``, so
  ``J = K(g)(pi + xi) - xi``: the Darboux momentum ``pi'`` of drie7 transported,
  minus a constant (the non-equivariance cocycle).
"""

from __future__ import annotations

from .._flow_checks import check_time
from .._flow_compiled import quat_to_x, x_to_quat
from .._flow_reference import (
    ModelMP,
    ReferenceTrajectory,
    euler_top_closed_form,
    reference_flow,
    reference_trajectory,
)
from .._integrators import DOP853, RK4, ExplicitRK, GaussLegendre, gbs_mp, triple_jump_weights
from .._invariants import casimirs, energy, momentum_map

# the scenes last: refimpl.scenes imports the flows above
from ..scenes import OUTPUTS, Plan, Scene, load_scene, parse_scene, plan, run_scene  # noqa: E402, I001
from ._common import numpy_rhs, qmul, scalar_rhs
from ._fast import NumpyModel, cached_model, fast_flow, fast_trajectory, integrate_fast
from .base import Adaptive, FixedStep, FlowResult, Integrator, check_tolerance
from .registry import METHODS, choose, method
from .step_doubling import StepDoubling

Method = Integrator
"""The old name of :class:`Integrator`."""

__all__ = [
    "reference_flow",
    "reference_trajectory",
    "ReferenceTrajectory",
    "euler_top_closed_form",
    "ModelMP",
    "fast_flow",
    "fast_trajectory",
    "NumpyModel",
    "cached_model",
    "METHODS",
    "Method",
    "Integrator",
    "FixedStep",
    "Adaptive",
    "FlowResult",
    "StepDoubling",
    "method",
    "choose",
    "integrate_fast",
    "energy",
    "casimirs",
    "momentum_map",
    "check_tolerance",
    "check_time",
    "DOP853",
    "RK4",
    "ExplicitRK",
    "GaussLegendre",
    "gbs_mp",
    "triple_jump_weights",
    "qmul",
    "numpy_rhs",
    "scalar_rhs",
    "quat_to_x",
    "x_to_quat",
    "Scene",
    "Plan",
    "load_scene",
    "parse_scene",
    "plan",
    "run_scene",
    "OUTPUTS",
]
