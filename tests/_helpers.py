"""Assertion helpers that explain themselves (property, inputs, observed vs expected, tolerance, ratio)."""

from __future__ import annotations

import numpy as np

from tstarg.refimpl import CATALOGUE_NAMES, catalogue
from tstarg.refimpl.accuracy import digits_of_agreement


def mp_matrix_to_array(m) -> np.ndarray:
    return np.array([[m[i, j] for j in range(m.cols)] for i in range(m.rows)], dtype=object)


def mp_digits(a, b, *, dps: int = 200) -> float:
    """Correct digits of ``a`` against ``b`` in the max norm: ``-log10(max|a-b| / max(max|b|, 1))``
    (:func:`refimpl.accuracy.digits_of_agreement`; a NaN on either side gives ``-inf``)."""
    return digits_of_agreement(a, b, dps=dps)


def assert_digits(a, b, digits: float, what: str) -> None:
    got = mp_digits(a, b)
    assert got >= digits, f"{what}: {got:.1f} correct digits, need >= {digits}"


def assert_within_bound(
    observed: np.ndarray, expected: np.ndarray, bound: np.ndarray, what: str, *, inputs: str = ""
) -> float:
    """Per point: ``max |observed - expected| <= bound``. Returns the worst error/bound ratio."""
    observed = np.asarray(observed, dtype=float)
    expected = np.asarray(expected, dtype=float)
    assert np.all(np.isfinite(observed)), f"{what}: non-finite values in the result ({inputs})"
    err = np.abs(observed - expected)
    err = err.reshape(err.shape[0], -1).max(axis=1) if err.ndim > 1 else err
    ratio = err / np.asarray(bound, dtype=float)
    worst = int(np.argmax(ratio))
    assert ratio[worst] <= 1.0, (
        f"{what}: error {err[worst]:.3g} exceeds its error bound {bound[worst]:.3g} "
        f"(ratio {ratio[worst]:.3g}) at point {worst}; {inputs}"
    )
    return float(ratio.max())


def regime_cases(regimes):
    """(algebra name, regime) pairs; ``near_degenerate`` is left out for abelian algebras, whose
    Delta = det(1 + S Upsilon) does not depend on pi (S = -Theta): no degenerate set to approach."""
    return [
        (n, r)
        for n in CATALOGUE_NAMES
        for r in regimes
        if not (r == "near_degenerate" and not catalogue(n).f.any())
    ]
