"""Outside its declared domain the implementation raises ``ValueError`` through every method it has (a
wrong number fails)."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from tstarg.oracles.float_judge import (
    conditioning,
)
from tstarg.refimpl.fast import implementation as fast

from .._common import (
    _call,
)
from ..check import ANY_METHOD, Check, Mutant, planted
from ..domain import Domain
from ..models import _hamiltonians


def _domain_refusal(impl, dom, stats):
    """Outside the declared domain every method must raise ValueError."""
    methods = [
        m
        for m in ("poisson_tensor", "hamiltonian_vector_field", "flow")
        if callable(getattr(impl, m, None))
    ]
    outside = []
    if dom.algebras is not None:
        outside.append("algebra")
    if not dom.theta:
        outside.append("theta")
    if not dom.upsilon:
        outside.append("upsilon")
    if not dom.gravity and any(m != "poisson_tensor" for m in methods):
        outside.append("gravity")
    if "flow" in methods and dom.max_abs_t is not None:
        outside.append("time")
    if "flow" in methods and dom.negative_t is False:
        outside.append("negative time")
    free = Domain()

    def body(ex):
        what, method, ((name, f, theta, ups, x, pi), inertia, pot) = ex
        n = f.shape[0]
        t = 0.1
        if what == "algebra" and dom.admits(f):
            reject()
        if what == "theta" and not np.any(theta):
            reject()
        if what == "upsilon" and not np.any(ups):
            reject()
        if what == "gravity":
            if method == "poisson_tensor":
                reject()
            pot = pot or {
                "kind": "gravity",
                "L": np.linspace(0.3, -0.4, n),
                "gamma": np.linspace(-0.5, 0.7, n),
            }
        if what in ("time", "negative time") and method != "flow":
            reject()
        if what == "time":
            t = 2 * dom.max_abs_t
        if what == "negative time":
            t = -0.1
        cond, _ = conditioning(f, theta, ups, x, pi)
        if not math.isfinite(cond) or cond > 1e6:
            return None
        if method == "poisson_tensor":
            args = (f, theta, ups, x, pi)
        elif method == "hamiltonian_vector_field":
            args = (f, theta, ups, inertia, pot, x, pi)
        else:
            args = (f, theta, ups, inertia, pot, x, pi, t)
        try:
            _call(impl, method, *args)
        except ValueError:
            stats[f"refused outside the domain ({what})"] = (
                stats.get(f"refused outside the domain ({what})", 0) + 1
            )
            return 0.0, None
        raise AssertionError(
            f"{method} returned a result outside the declared domain ({what}: {name}, "
            f"t = {t:g}): it must raise ValueError"
        )

    @st.composite
    def strat(draw):
        what = draw(st.sampled_from(outside), label="outside by")
        method = draw(st.sampled_from(methods), label="method")
        within = free if what == "algebra" else Domain(algebras=dom.algebras)
        return what, method, draw(_hamiltonians("generic", within))

    return (body, strat()) if outside else (None, "nothing lies outside the declared domain")


def _applies(impl, dom):
    return None if dom.declared else "no domain declared (the whole model space is certified)"


class FlowOnlyIgnoresDomain:
    """Only ``flow`` (refimpl.fast's), declaring the su(2)-only domain, never refusing outside it:
    it returns numbers for every algebra, Theta and Upsilon (issue 26's false PASS)."""

    name, version = "flow-only, su(2) declared, never refuses", "test"
    flow_tolerance = 1e-10  # refimpl.fast's
    domain: ClassVar[dict] = {"algebras": ["su(2)"], "theta": False, "upsilon": False}

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t):
        return fast.flow(f, theta, upsilon, inertia, potential, x0, pi0, t)


CHECK = Check(
    id="domain.refusal",
    needs=ANY_METHOD,
    equations="(declared domain)",
    build=_domain_refusal,
    order=120,
    budget=lambda k: max(4, k // 2),
    applies=_applies,
    mutants={
        **planted("domain_ignored"),
        "domain_ignored_flow_only": Mutant(
            "a flow-only implementation declaring the su(2)-only domain (Theta = Upsilon = 0) that "
            "never refuses outside it",
            FlowOnlyIgnoresDomain,
        ),
    },
)
