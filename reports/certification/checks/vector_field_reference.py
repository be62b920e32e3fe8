"""``(xdot, pidot)`` vs the reference, with random non-diagonal inertia, free and with gravity
(twee15)."""

from __future__ import annotations

import math

import numpy as np

from tstarg.oracles.float_judge import (
    C_CERT,
    ad,
    conditioning,
    eps_impl,
    max_err,
    phi1,
    tolerance,
)
from tstarg.refimpl.reference import DegeneratePointError

from .._common import (
    _REF,
    _aim,
    _call,
    _digits,
    _finite_array,
)
from ..check import Check, Variant
from ..models import _hamiltonians


def _vector_field_reference(impl, dom, stats, regime):
    def body(ex):
        (name, f, theta, ups, x, pi), inertia, pot = ex
        n = f.shape[0]
        try:
            xd, pd = _REF.hamiltonian_vector_field(f, theta, ups, inertia, pot, x, pi)
        except DegeneratePointError:
            return None
        cond, frame = conditioning(f, theta, ups, x, pi)
        cond *= np.linalg.cond(inertia)  # dK = I^-1 pi
        if not math.isfinite(cond) or cond * eps_impl(impl) * C_CERT * n >= 1:
            return None
        try:
            gx, gp = _call(impl, "hamiltonian_vector_field", f, theta, ups, inertia, pot, x, pi)
        except ValueError as exc:
            raise AssertionError(
                f"{name}: raised ValueError at a non-degenerate point: {exc}"
            ) from None
        got = np.concatenate([_finite_array(gx, (n,), "xdot"), _finite_array(gp, (n,), "pidot")])
        ref = np.concatenate([xd, pd])
        L = np.linalg.inv(phi1(-ad(f, x)))
        err = max_err(got, ref)
        force = (
            1.0
            if pot is None
            else max(1.0, float(np.abs(pot["L"]).max() * np.abs(pot["gamma"]).max()))
        )
        tol = tolerance(impl, n, cond, frame, ref) * max(1.0, float(np.max(np.abs(L)))) * force
        _aim(err / tol, "vector field ratio")
        return err / tol, _digits(err, max(1.0, float(np.max(np.abs(ref)))))

    return body, _hamiltonians(regime, dom)


def _regimes(impl, dom):
    return [
        Variant(regime, {"regime": regime})
        for regime in ("generic", "near_degenerate")
        if regime != "near_degenerate" or dom.upsilon
    ]


CHECK = Check(
    id="hamiltonian_vector_field.reference",
    needs=("hamiltonian_vector_field",),
    equations="vier10, vier11, twee16",
    build=_vector_field_reference,
    order=60,
    variants=_regimes,
)
