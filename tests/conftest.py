"""Shared test set-up: BLAS pinned to one thread, Hypothesis profiles, precision hygiene.

Profiles come from the one table :data:`properties.profiles.PROFILES` (select with
``--hypothesis-profile`` or ``TSTARG_PROFILE``): ``dev`` (fast, default locally), ``ci``
(derandomized, the default when ``CI`` is set), ``thorough``. Checks driven by the mpmath
reference use ``ref_examples()``, a fraction of the profile's budget.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import mpmath  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from tstarg.properties.profiles import default_profile, register_profiles  # noqa: E402

threadpool_limits(1)

register_profiles()
settings.load_profile(default_profile())


@pytest.fixture(autouse=True)
def _precision_hygiene():
    """A test that leaves mpmath's global precision changed fails (and the precision is restored
    for the next test); numpy floating-point warnings raise."""
    before = mpmath.mp.dps
    with np.errstate(all="raise", under="ignore"):
        yield
    after = mpmath.mp.dps
    mpmath.mp.dps = before
    assert after == before, (
        f"the test left mpmath's global precision at {after} digits (it was {before})"
    )
