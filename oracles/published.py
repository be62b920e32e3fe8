"""Published values the suite is judged against.

Second Betti numbers ``b2 = dim H^2(g, R)`` (trivial coefficients) of the catalogue:

* semisimple algebras (su(2), so(3), sl(2,R), so(4), su(3), sl(3,R), Bianchi VIII, IX): 0,
  Whitehead's second lemma (e.g. Jacobson, *Lie Algebras*, 1962, ch. III);
* ``R^n``: ``n(n-1)/2`` (every 2-form is a cocycle and none is a coboundary);
* Heisenberg ``h(2k+1)``: ``b2 = 2`` for ``k = 1`` and ``C(2k, 2) - 1`` for ``k >= 2``
  (L. J. Santharoubane, "Cohomology of Heisenberg Lie algebras",
  Proc. AMS 87 (1983) 23-28);
* 3-dimensional (Bianchi) algebras: ``b2 = b1`` for the unimodular (class A) ones by
  Poincare duality, ``b2 = b1 - 1`` for class B (Euler characteristic 0, ``b3 = 0``),
  with ``b1 = 3 - dim [g, g]``; see de Azcarraga & Izquierdo, *Lie groups, Lie
  algebras, cohomology and some applications in physics*, CUP 1995, ch. 6;
* aff(1): 0 (2-dimensional, non-unimodular); se(2): 1 (the central extension of
  the Euclidean group of the plane); se(3): 0 (perfect, Hochschild-Serre with
  ``(Lambda^2 R^3)^{so(3)} = 0``).

First Betti numbers ``b1 = dim H^1(g, R) = dim g - dim [g, g]`` (:data:`PUBLISHED_B1`):
0 for the semisimple and perfect algebras (Whitehead's first lemma; se(3) is perfect);
``n`` for ``R^n``; ``2k`` for ``h(2k+1)`` (Santharoubane 1983, above); for the Bianchi
algebras ``dim [g, g]`` is 0 (I), 1 (II, III), 2 (IV -- VII), 3 (VIII, IX) (Bianchi's
classification as tabulated by Ellis & MacCallum, "A class of homogeneous cosmological
models", Commun. Math. Phys. 12 (1969) 108-141); aff(1): 1; se(2): 1.
These satisfy the duality relations quoted above against :data:`PUBLISHED_H2`.
"""

from __future__ import annotations

__all__ = ["PUBLISHED_B1", "PUBLISHED_H2"]

# fmt: off
PUBLISHED_H2 = {
    "su(2)": 0, "so(3)[other basis]": 0, "sl(2,R)": 0, "so(4)": 0, "su(3)": 0, "sl(3,R)": 0,
    "R^1": 0, "R^3": 3, "h(3)": 2, "h(5)": 5,
    "Bianchi I": 3, "Bianchi II": 2, "Bianchi III": 1, "Bianchi IV": 0, "Bianchi V": 0,
    "Bianchi VI0": 1, "Bianchi VI_h(h=-1/4)": 0, "Bianchi VI_h(h=-2)": 0, "Bianchi VII0": 1,
    "Bianchi VII_h(h=1/9)": 0, "Bianchi VII_h(h=3)": 0, "Bianchi VIII": 0, "Bianchi IX": 0,
    "aff(1)": 0, "se(2)": 1, "se(3)": 0,
}

PUBLISHED_B1 = {
    "su(2)": 0, "so(3)[other basis]": 0, "sl(2,R)": 0, "so(4)": 0, "su(3)": 0, "sl(3,R)": 0,
    "R^1": 1, "R^3": 3, "h(3)": 2, "h(5)": 4,
    "Bianchi I": 3, "Bianchi II": 2, "Bianchi III": 2, "Bianchi IV": 1, "Bianchi V": 1,
    "Bianchi VI0": 1, "Bianchi VI_h(h=-1/4)": 1, "Bianchi VI_h(h=-2)": 1, "Bianchi VII0": 1,
    "Bianchi VII_h(h=1/9)": 1, "Bianchi VII_h(h=3)": 1, "Bianchi VIII": 0, "Bianchi IX": 0,
    "aff(1)": 1, "se(2)": 1, "se(3)": 0,
}
# fmt: on
