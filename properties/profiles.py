"""The Hypothesis profiles of tstarg: one table for the test suite and for ``tstarg verify``.

``dev`` is fast and randomized (the default locally), ``ci`` derandomized (the default when the
environment variable ``CI`` is set), ``thorough`` many examples. ``max_examples`` is the test
suite's budget per property; ``certify_examples`` that of ``tstarg certify``; ``verify_examples`` the budget per check of ``tstarg verify`` (whose
checks are each a whole property over many algebras, so fewer examples per check). Checks driven
by the mpmath reference take a fraction of the budget (:func:`ref_examples`).
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

__all__ = ["PROFILES", "register_profiles", "default_profile", "ref_examples", "verify_examples"]

PROFILES: dict[str, dict] = {
    "dev": {"max_examples": 15, "verify_examples": 6, "certify_examples": 8, "derandomize": False},
    "ci": {"max_examples": 25, "verify_examples": 20, "certify_examples": 15, "derandomize": True},
    "thorough": {
        "max_examples": 400,
        "verify_examples": 60,
        "certify_examples": 100,
        "derandomize": False,
    },
}


def register_profiles() -> None:
    """Register every profile of :data:`PROFILES` with Hypothesis (idempotent)."""
    for name, p in PROFILES.items():
        health = [HealthCheck.too_slow] + (
            [HealthCheck.data_too_large] if name == "thorough" else []
        )
        settings.register_profile(
            name,
            max_examples=p["max_examples"],
            deadline=None,
            derandomize=p["derandomize"],
            print_blob=True,
            suppress_health_check=health,
        )


def default_profile() -> str:
    """``TSTARG_PROFILE`` if set, else ``ci`` when ``CI`` is set, else ``dev``."""
    name = os.environ.get("TSTARG_PROFILE") or ("ci" if os.environ.get("CI") else "dev")
    if name not in PROFILES:
        raise ValueError(f"TSTARG_PROFILE must be one of {sorted(PROFILES)}, got {name!r}")
    return name


def verify_examples(profile: str) -> int:
    """Examples per check of ``tstarg verify`` under ``profile``."""
    if profile not in PROFILES:
        raise ValueError(f"profile must be one of {sorted(PROFILES)}, got {profile!r}")
    return PROFILES[profile]["verify_examples"]


def ref_examples(factor: float = 0.4) -> int:
    """Examples for a reference-driven (mpmath) property: a fraction of the active profile's budget."""
    return max(3, int(settings().max_examples * factor))
