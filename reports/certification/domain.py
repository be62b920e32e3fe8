"""Declared domains (issue 18): what an implementation says it supports, normalised."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tstarg.refimpl import CATALOGUE_NAMES, PROTOCOL, catalogue


@dataclass
class Domain:
    """An implementation's declared domain (module docstring), normalised."""

    algebras: object = None  # None, tuple of catalogue names, or a predicate f -> bool
    theta: bool = True
    upsilon: bool = True
    gravity: bool = True
    max_abs_t: float | None = None
    negative_t: bool | None = None
    declared: bool = False

    def admits(self, f) -> bool:
        if self.algebras is None:
            return True
        if callable(self.algebras):
            return bool(self.algebras(np.array(f, dtype=float)))
        return any(
            catalogue(nm).f.shape == f.shape and np.array_equal(catalogue(nm).f, f)
            for nm in self.algebras
        )

    def describe(self) -> str:
        if not self.declared:
            return "the whole model space (no domain declared)"
        parts = []
        if self.algebras is None:
            parts.append("every algebra")
        elif callable(self.algebras):
            parts.append(
                f"algebras accepted by {getattr(self.algebras, '__name__', 'a predicate')}"
            )
        else:
            parts.append(", ".join(self.algebras))
        if not self.theta:
            parts.append("Theta = 0")
        if not self.upsilon:
            parts.append("Upsilon = 0")
        if not self.gravity:
            parts.append("no potential")
        if self.max_abs_t is not None:
            parts.append(f"|t| <= {self.max_abs_t:g}")
        if self.negative_t is False:
            parts.append("t >= 0")
        if self.negative_t is True:
            parts.append("t of either sign")
        return ", ".join(parts)


_DOMAIN_KEYS = {
    "algebras",
    "theta",
    "upsilon",
    "gravity",
    "max_abs_t",
    "negative_t",
    "batched",
    "group",
}
"""``group``: the group the flows live on (:mod:`.group`; also an attribute ``group``)."""


def declared_domain(impl) -> Domain:
    """The ``domain`` attribute of ``impl`` (module docstring) as a :class:`Domain`; a clear
    ``ValueError`` naming the key for a malformed declaration."""
    raw = getattr(impl, "domain", None)
    if raw is None:
        return Domain()
    if not isinstance(raw, dict):
        raise ValueError(f"domain must be a dict, got {type(raw).__name__}")  # noqa: TRY004 - house rule: bad input is a ValueError
    unknown = set(raw) - _DOMAIN_KEYS
    if unknown:
        raise ValueError(
            f"domain has unknown keys {sorted(unknown)} (known: {sorted(_DOMAIN_KEYS)})"
        )
    algs = raw.get("algebras")
    if algs is not None and not callable(algs):
        if isinstance(algs, str):
            algs = [algs]
        algs = tuple(algs)
        bad = [a for a in algs if a not in CATALOGUE_NAMES]
        if bad or not algs:
            raise ValueError(
                f"domain['algebras'] must name catalogue algebras ({', '.join(CATALOGUE_NAMES)}) "
                f"or be a predicate on f; unknown: {bad}"
            )
    for k in ("theta", "upsilon", "gravity"):
        if not isinstance(raw.get(k, True), bool):
            raise ValueError(f"domain[{k!r}] must be True or False, got {raw[k]!r}")  # noqa: TRY004
    mt = raw.get("max_abs_t")
    if mt is not None and (not isinstance(mt, (int, float)) or not mt > 0 or not math.isfinite(mt)):
        raise ValueError(f"domain['max_abs_t'] must be a finite number > 0, got {mt!r}")
    neg = raw.get("negative_t")
    if neg is not None and not isinstance(neg, bool):
        raise ValueError(f"domain['negative_t'] must be True, False or absent, got {neg!r}")
    return Domain(
        algebras=algs,
        theta=raw.get("theta", True),
        upsilon=raw.get("upsilon", True),
        gravity=raw.get("gravity", True),
        max_abs_t=None if mt is None else float(mt),
        negative_t=neg,
        declared=True,
    )


def _batched(impl) -> bool:
    dom = getattr(impl, "domain", None)
    if isinstance(dom, dict) and "batched" in dom:
        return bool(dom["batched"])
    return bool(PROTOCOL.declared(impl, "batched"))
