"""Shared test set-up: BLAS pinned to one thread, Hypothesis profiles, numeric helpers.

Profiles (select with ``--hypothesis-profile`` or ``TSTARG_PROFILE``):
``dev`` (fast, default locally), ``ci`` (derandomized, the default when
``CI`` is set), ``thorough`` (many examples, no deadline). Checks driven by
the mpmath reference use ``ref_examples()``, a fraction of the profile's
budget, since each example costs milliseconds to seconds.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import mpmath  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

threadpool_limits(1)

settings.register_profile(
    "dev", max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "ci", max_examples=25, deadline=None, derandomize=True, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "thorough", max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large]
)
settings.load_profile(os.environ.get("TSTARG_PROFILE", "ci" if os.environ.get("CI") else "dev"))


def ref_examples(factor: float = 0.4) -> int:
    """Examples for a reference-driven (mpmath) property: a fraction of the profile's budget."""
    return max(3, int(settings().max_examples * factor))


@pytest.fixture(autouse=True)
def _precision_hygiene():
    """mpmath's global precision is restored after every test; numpy warnings raise."""
    dps = mpmath.mp.dps
    with np.errstate(all="raise", under="ignore"):
        yield
    mpmath.mp.dps = dps
    assert dps == 15, "a test left mpmath's global precision changed"
