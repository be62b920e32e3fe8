"""The identity checks of ``tstarg verify`` (properties.identity_checks.CHECKS), each run here under
the active Hypothesis profile: one list of checks for the command and the suite. A check passes
when every drawn example is within its error model (its ``extra["tolerance"]``); a negative
control passes when the identity fails on every broken example. The tests of the single
identities (test_closedness.py, test_jacobi.py, ...) add what the registry does not draw:
per-family and per-catalogue stratification, and the expected values of independent routes."""

from __future__ import annotations

import pytest
from hypothesis import settings

from tstarg.properties.identity_checks import CHECKS, CHECKS_BY_NAME, identity_checks

SLOW = {"darboux_flow[reference]", "negative[darboux_flow: xi -> -xi]"}


def _budget() -> int:
    """The per-check budget under pytest: 40% of the profile's examples (6 under dev, 10 under
    ci); the mpmath-driven checks take a third of it, at least 3 (IdentityCheck.examples)."""
    return max(3, int(settings().max_examples * 0.4))


@pytest.mark.parametrize(
    "check",
    [
        pytest.param(c, id=c.name, marks=[pytest.mark.slow] if c.name in SLOW else [])
        for c in CHECKS
    ],
)
def test_registered_check(check):
    k = _budget() if check.name not in SLOW else 30
    if not check.applies(k):
        pytest.skip(f"{check.name}: needs refimpl.flows")
    res = check.run(k, seed=None)  # seed None: Hypothesis' own (the profile's derandomize)
    assert res.passed, f"{res.name}: {res.detail}\n{res.falsifying_example}"
    assert res.examples >= 1, f"{res.name}: no example was judged ({res.skipped} skipped)"


def test_the_provider_runs_the_registry(monkeypatch):
    """``tstarg verify``'s provider runs the registry's checks, in order, each with the budget of
    its kind: all of them but the flow's negative control at 20 examples (a twelfth, 1, for the
    flow check; a third, 6, for the mpmath ones), that one too at 60 (a thirtieth: 2)."""
    import tstarg.properties.identity_checks as ic

    seen: list[tuple[str, int]] = []
    monkeypatch.setattr(
        ic, "run_property", lambda name, *a, **kw: seen.append((name, kw["max_examples"]))
    )
    names = [c.name for c in CHECKS]
    assert len(set(names)) == len(names) == len(CHECKS_BY_NAME)
    identity_checks(20, 0)
    assert [n for n, _ in seen] == names[:-1]
    got = dict(seen)
    assert (got["closedness[exact]"], got["closedness[mp]"], got["darboux_flow[reference]"]) == (
        20,
        6,
        1,
    )
    seen.clear()
    identity_checks(60, 0)
    assert [n for n, _ in seen] == names
    assert dict(seen)["negative[darboux_flow: xi -> -xi]"] == 2
