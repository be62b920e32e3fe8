"""``P`` vs the proven Arb enclosure of the exact tensor in every conditioning regime (generic, near
the degenerate set, large momenta, near the chart boundary)."""

from __future__ import annotations

import math

import numpy as np

from tstarg.oracles.float_judge import (
    C_CERT,
    cond_omega,
    conditioning,
    eps_impl,
    tolerance,
)
from tstarg.properties.strategies import REGIMES
from tstarg.refimpl.reference import DegeneratePointError
from tstarg.refimpl.rigorous import UndecidedError, error_bounds

from .._common import (
    _JUDGE,
    _aim,
    _call,
    _digits,
    _finite_array,
)
from ..check import Check, Variant, planted
from ..models import _models


# Each builder returns ``(body, strategy)``; ``stats`` collects counts that the certificate reports.
def _poisson_reference(impl, dom, stats, regime):
    def body(ex):
        name, f, theta, ups, x, pi = ex
        try:  # the judge: balls that provably contain the exact tensor of these float64 inputs
            balls = _JUDGE.poisson_tensor_balls(f, theta, ups, x, pi)
        except (DegeneratePointError, UndecidedError):
            return None
        ref = balls.mid
        cond, frame = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond * eps_impl(impl) * C_CERT * f.shape[0] >= 1:
            return None  # numerically degenerate for this precision: judged by the degenerate check
        try:
            got = _finite_array(
                _call(impl, "poisson_tensor", f, theta, ups, x, pi), ref.shape, "poisson_tensor"
            )
        except ValueError as exc:
            raise AssertionError(
                f"{name}: raised ValueError at a non-degenerate point (cond {cond:.3g}): {exc}"
            ) from None
        err = float(np.max(error_bounds(got, balls)[1]))  # proven: |got - exact| <= err
        # error model: the conditioning of the problem (Phi and the frame), or that of the obvious
        # first-principles route, a plain inverse of the holonomic omega_L (errs by
        # ~ n eps cond(W_h) max|P|): a correct float64 implementation may take either
        kappa = max(1.0, cond_omega(f, theta, ups, x, pi) / (cond * frame))
        tol = tolerance(impl, f.shape[0], cond, frame * kappa, ref)
        _aim(err / tol, "poisson ratio")
        return err / tol, _digits(err, max(1.0, float(np.max(np.abs(ref)))))

    return body, _models(regime, dom)


def _regimes(impl, dom):
    # the degenerate neighbourhood gets twice the budget: errors that appear only there
    # (cond(Phi) 1e4..1e9) are the ones a uniform search misses
    out = []
    for regime in REGIMES:
        if regime == "near_degenerate" and not dom.upsilon:
            out.append(
                Variant(regime, skip="Upsilon = 0 in the declared domain: no degenerate set")
            )
            continue
        out.append(
            Variant(regime, {"regime": regime}, factor=2 if regime == "near_degenerate" else 1)
        )
    return out


CHECK = Check(
    id="poisson_tensor.reference",
    needs=("poisson_tensor",),
    equations="vier9",
    build=_poisson_reference,
    order=10,
    variants=_regimes,
    mutants=planted("small_dims_only"),
)
