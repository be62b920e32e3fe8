"""The one registry of certification checks: every module of :mod:`reports.certification.checks`
that defines ``CHECK`` (a :class:`~reports.certification.check.Check`), in their ``order``.

A new check is one new file in ``checks/``; nothing else changes (the certificate, ``--check``,
skips files, the parallel runner and the mutation kill rate read this registry). For example, a
time-reversal check ``checks/flow_reversal.py``::

    from hypothesis import strategies as st
    from tstarg.oracles.float_judge import conditioning, flow_tol, max_err
    from .._common import _finite_array, _flow_call
    from ..check import Check, Mutant
    from ..models import _hamiltonians

    def _build(impl, dom, stats):
        def body(ex):
            ((_name, f, theta, ups, x, pi), inertia, pot), t = ex
            args = (f, theta, ups, inertia, pot)
            x1, p1 = _flow_call(impl, dom, stats, (*args, x, pi), t)
            x0, p0 = _flow_call(impl, dom, stats, (*args, x1, p1), -t)
            cond, frame = conditioning(f, theta, ups, x, pi)
            tol = 2 * flow_tol(impl, f.shape[0], cond, frame) * max(1.0, abs(pi).max())
            return max(max_err(x0, x), max_err(p0, pi)) / tol, None

        return body, st.tuples(_hamiltonians("generic", dom), st.floats(0.1, 1.0))

    CHECK = Check(
        id="flow.reversal", needs=("flow",), equations="vier10, vier11", build=_build,
        order=85, budget=lambda k: k,
        mutants={"abs_time": Mutant("integrates to |t|", lambda: AbsTimeFlow())},
    )

It then runs in ``tstarg certify``, is listed by ``--check``, and its mutant joins the kill rate."""

from __future__ import annotations

import importlib
import pkgutil

from ..mutants import MUTATIONS as _PLAIN_MUTATIONS
from ..mutants import Plain
from . import checks as _checks_pkg
from .check import Check, Mutant

__all__ = ["CHECKS", "MUTANT_CHECKS", "MUTATIONS", "REGISTRY", "get", "missing", "mutant"]


def _discover() -> dict[str, Check]:
    found = []
    for info in pkgutil.iter_modules(_checks_pkg.__path__):
        mod = importlib.import_module(f"{_checks_pkg.__name__}.{info.name}")
        check = getattr(mod, "CHECK", None)
        if isinstance(check, Check):
            found.append(check)
    found.sort(key=lambda c: (c.order, c.id))
    ids = [c.id for c in found]
    dup = {i for i in ids if ids.count(i) > 1}
    if dup:
        raise RuntimeError(f"certification checks defined twice: {sorted(dup)}")
    return {c.id: c for c in found}


REGISTRY: dict[str, Check] = _discover()
"""Check id -> :class:`Check`, in the order the battery runs them."""

CHECKS: dict[str, str] = {cid: c.method for cid, c in REGISTRY.items()}
"""Check id -> the protocol method it is named for (``REGISTRY[cid].needs``: every method it can
run through)."""

MUTANT_CHECKS: dict[str, list[str]] = {
    name: [cid] for cid, c in REGISTRY.items() for name in c.mutants
}
"""Mutant name -> the check it is planted against: certified on that check only, it must fail (the
check has teeth by itself); the mutants of :data:`reports.mutants.MUTATIONS` not listed run the
whole battery."""

MUTATIONS: dict[str, str] = dict(_PLAIN_MUTATIONS)
for _c in REGISTRY.values():
    for _name, _m in _c.mutants.items():
        if isinstance(_m, Mutant):
            MUTATIONS[_name] = _m.description
"""Every planted mutant: name -> description (those of :mod:`reports.mutants` and those defined
beside their checks)."""


def get(cid: str) -> Check:
    try:
        return REGISTRY[cid]
    except KeyError:
        raise ValueError(f"unknown check id {cid!r} (known: {', '.join(REGISTRY)})") from None


def missing(cid: str, provided) -> str | None:
    """Why check ``cid`` cannot run on an implementation providing the methods ``provided``
    (None: it can run through one of them)."""
    return get(cid).missing(provided)


def mutant(name: str):
    """A fresh instance of the planted mutant ``name`` (None: the correct plain implementation)."""

    if name is None or name in _PLAIN_MUTATIONS:
        return Plain(name)
    for c in REGISTRY.values():
        m = c.mutants.get(name)
        if isinstance(m, Mutant):
            return m.make()
    raise ValueError(f"unknown mutant {name!r}")
