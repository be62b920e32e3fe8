"""``P^T = -P`` to the rounding of a plain inversion of omega_L (the error model of
:mod:`tstarg.oracles.float_judge`)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    C_CERT,
    cond_omega,
    conditioning,
    eps_impl,
)

from .._common import (
    _aim,
    _call,
    _finite_array,
)
from ..check import Check, planted
from ..models import _models


def _poisson_antisymmetry(impl, dom, stats):
    def body(ex):
        name, f, theta, ups, x, pi = ex
        n = f.shape[0]
        cond, frame = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond * eps_impl(impl) * C_CERT * n >= 1:
            return None
        try:
            got = _finite_array(
                _call(impl, "poisson_tensor", f, theta, ups, x, pi),
                (2 * n, 2 * n),
                "poisson_tensor",
            )
        except ValueError as exc:
            raise AssertionError(
                f"{name}: raised ValueError at a non-degenerate point (cond {cond:.3g}): {exc}"
            ) from None
        if not np.all(np.isfinite(got)):
            raise AssertionError(f"{name}: non-finite Poisson tensor at a non-degenerate point")
        err = float(np.max(np.abs(got + got.T)))
        # error model: a plain inverse of W_h is asymmetric by ~ n eps cond(W_h) max|P| (module docstring)
        kappa = max(cond * frame, cond_omega(f, theta, ups, x, pi))
        tol = C_CERT * n * eps_impl(impl) * kappa * max(1.0, float(np.max(np.abs(got))))
        _aim(err / tol, "antisymmetry ratio")
        return err / tol, None

    return body, st.one_of(
        *[_models(r, dom) for r in ("generic", "large_momenta", "near_chart_boundary")]
    )


CHECK = Check(
    id="poisson_tensor.antisymmetry",
    needs=("poisson_tensor",),
    equations="vier9",
    build=_poisson_antisymmetry,
    order=20,
    budget=lambda k: max(5, k // 2),
    mutants=planted("pp_block_psi_left"),
)
