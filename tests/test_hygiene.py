"""The suite's own guards can fail: precision hygiene, and no NaN passes a closeness helper."""

from __future__ import annotations

import math
from fractions import Fraction
from pathlib import Path

import mpmath
import pytest

from tests._helpers import assert_digits, assert_within_bound, mp_digits
from tstarg.refimpl.accuracy import correct_digits, digits_of_agreement, max_abs, max_abs_diff

CONFTEST = Path(__file__).with_name("conftest.py")


def test_precision_hygiene_fixture_fails_a_leaking_test(pytester):
    """A planted test that leaves mpmath's precision at 30 digits errors at teardown; a clean one passes."""
    pytester.makeconftest(CONFTEST.read_text())
    pytester.makepyfile(
        test_planted="""
import mpmath

def test_leaks():
    mpmath.mp.dps = 30

def test_clean():
    with mpmath.workdps(30):
        pass
"""
    )
    result = pytester.runpytest_inprocess("-p", "no:cacheprovider")
    result.assert_outcomes(passed=2, errors=1)
    result.stdout.fnmatch_lines(["*left mpmath's global precision at 30 digits*"])
    assert mpmath.mp.dps == 15


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_no_nan_passes_the_digits_helpers(bad):
    """NaN or infinity on either side is never agreement: -inf digits, infinite difference."""
    assert mp_digits([1.0, bad], [1.0, 2.0]) == -math.inf
    assert mp_digits([1.0, 2.0], [1.0, bad]) == -math.inf
    assert digits_of_agreement([bad], [bad]) == -math.inf
    assert max_abs_diff([bad], [0.0])[0] == mpmath.inf
    assert max_abs([0.5, bad]) == mpmath.inf
    with pytest.raises(AssertionError):
        assert_digits([1.0, bad], [1.0, 2.0], 10, "planted NaN")
    with pytest.raises(AssertionError):
        assert_within_bound([[bad]], [[0.0]], [1.0], "planted NaN")


def test_digits_helper_on_known_values():
    """Digits from first principles: 1.1 vs 1 is one digit; an exact match is infinite; shapes must agree."""
    assert abs(digits_of_agreement([1.1], [1]) - 1.0) < 1e-12
    with mpmath.workdps(40):
        third = mpmath.mpf(1) / 3
    assert digits_of_agreement([Fraction(1, 3)], [third], dps=60) >= 39
    assert digits_of_agreement([2, 3], [2, 3]) == math.inf
    assert digits_of_agreement([1, 2, 3], [1, 2]) == -math.inf
    assert correct_digits(mpmath.mpf("1e-20"), 100) == pytest.approx(22.0, abs=1e-9)
