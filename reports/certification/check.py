"""One certification check: what it needs, what it costs, how it is built, what proves it.

Every file of :mod:`reports.certification.checks` defines one :class:`Check` named ``CHECK``;
:mod:`reports.certification.registry` finds them. A check is

* ``id``: the name in certificates, ``--check`` and skips/xfails files;
* ``needs``: the protocol methods it can run through (any one of them suffices);
* ``equations``: the paper's equations it tests (for the certificate);
* ``build(impl, dom, stats, **variant)``: ``(body, strategy)`` for
  :func:`properties.runner.run_property`, or ``(None, reason)`` when nothing is to be judged;
  ``stats`` collects counts that the certificate reports;
* ``budget(k)``: examples for a run of ``k`` examples per check;
* ``applies(impl, dom)``: why the check does not apply (None: it applies), beyond ``needs``;
* ``variants(impl, dom)``: the variants run under one id (e.g. the conditioning regimes of
  ``poisson_tensor.reference``), each a :class:`Variant`; one plain variant by default;
* ``extra(impl)``: entries added to the result's ``extra`` (e.g. the declared order);
* ``mutants``: the planted mutants that prove the check has teeth: certified on this check
  alone, each must fail (:mod:`reports.mutants` holds the shared plain implementation; a mutant is
  a name of :data:`reports.mutants.MUTATIONS` or a :class:`Mutant` defined beside the check).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from tstarg.refimpl import PROTOCOL

from ..mutants import MUTATIONS

__all__ = ["ANY_METHOD", "Check", "Mutant", "Variant"]

ANY_METHOD = PROTOCOL.method_names
"""``needs`` of a check that runs through whichever protocol method exists (every method of the
spec, :data:`tstarg.refimpl.PROTOCOL`)."""


@dataclass(frozen=True)
class Variant:
    """One run under a check id: ``suffix`` (shown as ``id[suffix]``), keyword arguments of the
    builder, a multiplier of the budget, and ``skip``: a reason to skip it instead (stated in the
    certificate)."""

    suffix: str | None = None
    kwargs: dict = field(default_factory=dict)
    factor: int = 1
    skip: str | None = None
    equations: str | None = None


@dataclass(frozen=True)
class Mutant:
    """A planted mistake defined beside its check: a description and a factory of the broken
    implementation."""

    description: str
    make: Callable[[], Any]


def _same(k: int) -> int:
    return k


@dataclass(frozen=True)
class Check:
    id: str
    needs: tuple[str, ...]
    equations: str
    build: Callable
    order: int
    budget: Callable[[int], int] = _same
    applies: Callable | None = None
    variants: Callable | None = None
    extra: Callable | None = None
    mutants: dict = field(default_factory=dict)
    sentinels: Callable | None = None
    """``sentinels(impl, dom) -> [example, ...]``: examples of the check's own type run first, before
    any drawn one, under every seed and budget (the cases it must never miss; each inside ``dom``)."""

    @property
    def method(self) -> str:
        """The protocol method named for this check (the first of ``needs``)."""
        return self.needs[0]

    def missing(self, provided) -> str | None:
        """Why this check cannot run on an implementation providing ``provided`` (None: it can)."""
        if any(m in provided for m in self.needs):
            return None
        if len(self.needs) == 1:
            return f"the implementation has no method {self.needs[0]!r}"
        return "the implementation has none of the protocol's methods"

    def plan(self, impl, dom) -> list[Variant]:
        return [Variant()] if self.variants is None else list(self.variants(impl, dom))


def planted(*names: str) -> dict:
    """``mutants=`` entries for mistakes of the shared plain implementation
    (:data:`reports.mutants.MUTATIONS`): name -> description."""

    return {n: MUTATIONS[n] for n in names}
