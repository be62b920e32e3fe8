"""Certification of implementations of the protocol (docs/design.md) against independent judges.

A package: each check is one object in one file of ``checks/`` (:class:`check.Check`: its id, the
methods it needs, its budget, its builder and the planted mutants that prove it), found through one
registry (:mod:`.registry`); the float64 judge and the error models sit with the oracles
(:mod:`tstarg.oracles.float_judge`). Adding a check: one file in ``checks/`` (:mod:`.registry`).

Public API:

* :func:`certify` -- run the battery on an implementation object; returns a :class:`Certificate`;
* :func:`load_target` -- ``"module:object"`` to the object;
* :data:`CHECKS` -- the check ids, each with the method it needs;
* :func:`declared_domain` -- the implementation's declared domain (below), normalised.

The battery (each check drawn by Hypothesis, shrunk to a minimal failing example). Models are
drawn from the whole model space (inside the declared domain): catalogue algebras, catalogue
algebras in a random basis, random solvable and nilpotent algebras, semidirect products, direct
sums and Bianchi class B algebras (``properties.strategies.lie_algebras``), with random cocycles
Theta and Upsilon.

``poisson_tensor.reference``
    ``P`` vs the 30-digit reference in every conditioning regime (generic, near the degenerate
    set, large momenta, near the chart boundary);
``poisson_tensor.antisymmetry``
    ``P^T = -P`` to the rounding of a plain inversion of omega_L (the error model below);
``poisson_tensor.degenerate``
    at a point of the degenerate set Pi_1 (exactly representable) the implementation raises
    ``ValueError`` or returns non-finite values; finite numbers there fail;
``poisson_tensor.batch`` (batched implementations)
    for every method: leading batch axes of rank 0 to 3 (sizes 1 included), given as arrays or
    nested lists; each point equals the same point evaluated alone; shapes as the protocol says;
``protocol.inputs``
    for every method: the caller's arrays are unchanged after the call; lists give the same
    result as arrays; outputs are finite float64 arrays of the protocol's shapes; interleaved calls
    with different models through the *same* caller buffers (refilled in place) each agree with
    the reference (no stale caches keyed by object identity, dimension or call order);
``hamiltonian_vector_field.reference``
    ``(xdot, pidot)`` vs the reference, with random non-diagonal inertia, free and with gravity
    (twee15);
``flow.reference``
    the state at ``|t| <= 1`` vs proven balls of the whole state (``tstarg-rigorous``, Arb at 64
    bits: an interval Taylor method with Lohner's wrapping, ``Upsilon != 0`` by the ball recurrence
    of the solve by ``Phi``, ``x`` by a proven principal logarithm; the balls' radius, the
    ``judge_error``, added to the tolerance), gravity and non-diagonal inertia included; negative
    times from the judge's end point back, against the balls of the backward flow. Where the balls
    refuse (counted by reason) the mpmath reference judges, with negative times by the round trip
    ``flow(flow_ref(z0, |t|), -|t|) = z0``; its cost is estimated first (:func:`reference_work`),
    examples over :data:`REFERENCE_WORK_LIMIT` are drawn again (counted in the certificate, never
    integrated), and reference results are cached across shrink steps;
``flow.long``
    the state at ``t`` anywhere in ``[-T, T]`` (``T = min(FLOW_T_MAX, domain max_abs_t)``) vs an
    independent float64 judge (scipy's DOP853 at rtol 1e-13 on the body system with ``Ad(g)``
    carried along, its own error estimated by a second run at rtol 1e-12): compared chart-free,
    through ``Ad(g) = expm(ad_x)`` and ``pi``, and through ``x`` too while ``x(t)`` stays well
    inside the chart (where it is unique);
``flow.order`` (a declared ``order`` and ``flow(..., steps=N)``)
    the error against the judge for doubling step counts; the fitted order must reach the
    declared one (within 0.5);
``flow.drift`` (implementations declaring ``order`` or ``poisson_integrator``)
    energy (and, where known, Casimir) drift over long times: at most Brouwer's law
    ``C tol sqrt(t)`` for the accuracy ``tol`` the implementation promises (bounded, ``C tol``,
    for implementations declaring ``poisson_integrator = True``);
``flow.poisson_map`` (``poisson_integrator = True`` and ``steps=``)
    the flow map with few fixed steps is a Poisson map: ``D Phi P D Phi^T = P o Phi``, with
    ``D Phi`` by Richardson-extrapolated central differences and ``P`` from the reference;
``domain.refusal`` (a declared domain)
    outside its declared domain the implementation raises ``ValueError`` (a wrong number fails).

Declared domains (issue 18). An implementation may declare ``domain`` (a dict), all keys
optional: ``"algebras"``: a list of catalogue names (exact catalogue constants only) or a
predicate ``f -> bool`` on the structure constants; ``"theta"``, ``"upsilon"``, ``"gravity"``:
``False`` when that term is not supported (then only Theta = 0, Upsilon = 0, or no potential
are drawn); ``"max_abs_t"``: the largest ``|t|`` of its flows; ``"negative_t"``: ``True``
(supported), ``False`` (refused) or absent (a ``ValueError`` refusal of ``t < 0`` is accepted
and stated in the certificate). ``batched`` stays the protocol's attribute. The certification
draws only inside the domain, says so in the certificate, and checks refusal outside it.

Error model (every check; docs/conventions.md "Errors and tolerances"):
``tol = C * n * eps_impl * kappa * frame * scale`` at the point, with ``C = 8``,
``kappa = max(cond_phi, cond_data) + route`` (``cond_phi = ||Phi||_F ||Phi^-1||_F / n``,
``cond_data = ||Phi^-1||_F (1 + ||S||_F ||U||_F) / sqrt(n)``; ``route = e^min(||ad_x||_1, 5.37) + s``
the error factor of the standard routes to the frame ``phi1(-ad_x)``: series, expm with scaling and
squaring, Van Loan's block; :func:`expm_route`), ``frame = 1/(1 - r)``,
``r >= ||ad_x||_2 / 2 pi``, ``scale = max(1, max|ref|)`` and
``eps_impl = 10^-precision_digits`` (float64's eps when absent). Antisymmetry uses in addition
the condition of the holonomic omega_L matrix ``W_h`` (``P = -W_h^-1``): an inverse computed
without symmetrisation is asymmetric by up to ``~ n eps cond(W_h) max|P|``. Flows use
``max(flow_tolerance, that)`` with the declared ``flow_tolerance`` (default 1e-9).
"""

from __future__ import annotations

from tstarg.oracles.float_judge import C_CERT, reference_work
from tstarg.oracles.float_judge import FloatJudge as _Judge
from tstarg.oracles.float_judge import ad as _ad
from tstarg.oracles.float_judge import centre_representation as _centre_representation
from tstarg.oracles.float_judge import compare_state as _compare_state
from tstarg.oracles.float_judge import conditioning as _conditioning
from tstarg.oracles.float_judge import meets_degenerate_set as _meets_degenerate_set

from ._common import (
    _FLOW_CACHE,
    ALLOW_CHART_REFUSAL,
    FLOW_T_MAX,
    JUDGE,
    REFERENCE_WORK_LIMIT,
    _flow_call,
    _judge_group,
    _judge_state,
)
from .certificate import Certificate, _read_ids, reproduce_command, write_certificate
from .check import Check, Mutant, Variant
from .domain import Domain, declared_domain
from .registry import CHECKS, MUTANT_CHECKS, MUTATIONS, REGISTRY
from .run import (
    certificate_checks,
    certify,
    certify_parallel,
    certify_target,
    kill_rate,
    load_target,
)

__all__ = [
    "ALLOW_CHART_REFUSAL",
    "CHECKS",
    "C_CERT",
    "FLOW_T_MAX",
    "JUDGE",
    "MUTANT_CHECKS",
    "MUTATIONS",
    "REFERENCE_WORK_LIMIT",
    "REGISTRY",
    "Certificate",
    "Check",
    "Domain",
    "Mutant",
    "Variant",
    "_FLOW_CACHE",
    "_Judge",
    "_ad",
    "_centre_representation",
    "_compare_state",
    "_conditioning",
    "_flow_call",
    "_judge_group",
    "_judge_state",
    "_meets_degenerate_set",
    "_read_ids",
    "certificate_checks",
    "certify",
    "certify_parallel",
    "certify_target",
    "declared_domain",
    "kill_rate",
    "load_target",
    "reference_work",
    "reproduce_command",
    "write_certificate",
]
