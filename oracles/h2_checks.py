"""Second Betti numbers judged by published tables (zeven1, zeven3): ``dim H^2`` computed exactly by
refimpl's cohomology against :data:`oracles.published.PUBLISHED_H2`, on the catalogue, in random
bases, on direct sums (Kunneth) and on class B Bianchi algebras."""

from __future__ import annotations

import math
from fractions import Fraction

from hypothesis import strategies as st

from tstarg.properties import identities as idn
from tstarg.properties.strategies import basis_changes
from tstarg.refimpl import LieAlgebra, bianchi, catalogue, cohomology

from .published import PUBLISHED_H2

__all__ = ["h2_published", "h2_examples", "h2_example"]


def h2_published(name) -> tuple[float, float | None]:
    got = cohomology(catalogue(name), exact=True).dim_h2
    return (0.0 if got == PUBLISHED_H2[name] else float("inf")), None


def _b1(alg: LieAlgebra) -> int:
    return alg.dim - alg.derived_dim()


@st.composite
def h2_examples(draw):
    """``(algebra, expected dim H^2, why)`` with the expectation from a published value, not our code:

    * a catalogue algebra in a random rational basis: ``dim H^2`` is basis-independent, so the
      published value of oracles/published.py;
    * a direct sum: Kunneth, ``b2(g+h) = b2(g) + b2(h) + b1(g) b1(h)`` with published ``b2``;
    * a class B Bianchi algebra with random rational ``a``: ``b2 = b1 - 1`` (de Azcarraga &
      Izquierdo, ch. 6; see oracles/published.py), ``b1 = 3 - dim [g, g]``.
    """
    kind = draw(st.sampled_from(["basis", "sum", "class B"]), label="h2 oracle")
    rational = [nm for nm in PUBLISHED_H2 if catalogue(nm).is_rational and catalogue(nm).dim <= 6]
    if kind == "basis":
        nm = draw(st.sampled_from(rational), label="algebra")
        base = catalogue(nm)
        c = draw(basis_changes(base.dim), label="C")
        return base.change_basis(c), PUBLISHED_H2[nm], f"published b2 of {nm}, basis-independent"
    if kind == "sum":
        small = [nm for nm in rational if catalogue(nm).dim <= 3]
        a = draw(st.sampled_from(small), label="g")
        b = draw(st.sampled_from(small), label="h")
        g, h = catalogue(a), catalogue(b)
        return (
            g.direct_sum(h),
            PUBLISHED_H2[a] + PUBLISHED_H2[b] + _b1(g) * _b1(h),
            f"Kunneth for {a} + {b}",
        )
    typ = draw(st.sampled_from(["III", "IV", "V", "VI_h", "VII_h"]), label="type")
    if typ in ("III", "IV", "V"):
        alg = bianchi(typ)
    else:
        a = draw(
            st.sampled_from([Fraction(1, 2), Fraction(2), Fraction(3, 2), Fraction(1, 3)]),
            label="a",
        )
        alg = bianchi(typ, -a * a if typ == "VI_h" else a * a)
    return alg, _b1(alg) - 1, "class B Bianchi: b2 = b1 - 1"


def h2_example(ex):
    alg, expected, _ = ex
    got = idn.h2_exact(alg)
    return idn.Measurement(
        abs(got - expected),
        0.0,
        math.inf if got == expected else None,
        f"dim H^2 = {got}, expected {expected}",
    )
