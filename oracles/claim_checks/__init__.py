"""The checks of the paper's claims, each from first principles: the judge is never the code under
test (refimpl may supply inputs, such as a catalogue algebra or a reference vector field that a
check compares with the printed formula, never the verdict).

One module per section of the paper, each with its :data:`CHECKS` (name -> function):
:mod:`.un` (R^N), :mod:`.deux` (T*G, frames, Euler equations, gravity), :mod:`.trois` (Liouville
forms, Darboux, the labels), :mod:`.quatre` (the modified structure: Phi, Psi, Delta, W),
:mod:`.cinq` (su(2), the Gotay-Nester-Hinds examples), :mod:`.sept` (cohomology, Whitehead).
Shared tools: :mod:`.common` (:class:`Outcome`, the mpmath error model), :mod:`.group_model` (su(2)
as 2x2 matrices ``exp(x^a E_a)``, coordinates by ``mpmath.logm``, derivatives by ``mpmath.diff``),
:mod:`.algebras` (structure constants written out here, random exact models), :mod:`.paper` (the
paper's source and its label sequence).

Every check returns an :class:`Outcome` (``ok``, ``error``, ``tolerance``, ``detail``). A check
named ``..._printed`` evaluates a formula as printed and must FAIL where the paper is wrong;
``..._corrected`` states the correction and must pass. ``..._counterexample`` checks pass when they
exhibit the counterexample they name (a hypothesis is needed); ``..._attained`` checks pass when a
bound is attained (or, as stated in their docstring, shown not to be). The registry
(:mod:`oracles.claims`, data in oracles/registry/) says which check backs which claim.

Tolerances: the mpmath route works at ``DPS + 15`` digits and asks for ``DPS - 8`` correct digits of
the scale (:func:`.common.tolerance`); exact checks (sympy, rational inputs) have none.
"""

from __future__ import annotations

from . import cinq, deux, quatre, sept, trois, un
from .common import DPS, Outcome, tolerance
from .paper import PAPER_LABELS, paper_labels, paper_path

__all__ = [
    "CHECKS",
    "DPS",
    "PAPER_LABELS",
    "SECTIONS",
    "Outcome",
    "clear_cache",
    "paper_labels",
    "paper_path",
    "run_check",
    "tolerance",
]

SECTIONS = {"un": un, "deux": deux, "trois": trois, "quatre": quatre, "cinq": cinq, "sept": sept}
"""The check modules by the paper's section (its ``\\section`` labels)."""


def _collect() -> dict:
    out: dict = {}
    for mod in SECTIONS.values():
        for name, fn in mod.CHECKS.items():
            if name in out:  # pragma: no cover - guards the one-name-one-check rule at import
                raise ValueError(f"check {name!r} registered twice ({mod.__name__})")
            out[name] = fn
    return out


CHECKS = _collect()
"""Every check by name, in the order of the paper's sections."""

_CACHE: dict = {}


def run_check(name: str, *, fresh: bool = False) -> Outcome:
    """Run one check of :data:`CHECKS` by name (cached per process; the checks are deterministic)."""
    if name not in CHECKS:
        raise ValueError(f"unknown claim check {name!r}; known: {sorted(CHECKS)}")
    if fresh or name not in _CACHE:
        _CACHE[name] = CHECKS[name]()
    return _CACHE[name]


def clear_cache() -> None:
    """Forget the cached outcomes (the next :func:`run_check` runs the check again)."""
    _CACHE.clear()
