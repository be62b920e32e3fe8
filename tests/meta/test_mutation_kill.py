"""Test the tests: the certification battery rejects every deliberately broken implementation
(tests/meta/mutants.py) and accepts the correct ones. The kill rate is the fraction rejected."""

from __future__ import annotations

import pytest

from tstarg.reports.certification import certify
from tstarg.reports.mutants import MUTATIONS, Plain

SEED = 0
EXAMPLES = 10


@pytest.mark.parametrize("mutation", sorted(MUTATIONS))
def test_certify_rejects_mutant(mutation):
    impl = Plain(mutation)
    checks = None
    if mutation == "flow_wrong_stage":
        pytest.importorskip("tstarg.refimpl.flows", reason="the flow mutant needs the reference flow")
        checks = ["flow.reference"]
    cert = certify(impl, max_examples=EXAMPLES, seed=SEED, target=f"tests.meta.mutants:Plain({mutation!r})", checks=checks, stop_on_failure=True,
                   shrink=False)
    assert not cert.passed, f"mutation {mutation!r} ({MUTATIONS[mutation]}) survived:\n{cert.summary()}"


@pytest.mark.parametrize("target", ["plain", "fast", "reference"])
def test_certify_accepts_correct_implementations(target):
    from tstarg.refimpl.fast import implementation as fast
    from tstarg.refimpl.reference import Reference

    impl = {"plain": Plain(None), "fast": fast, "reference": Reference(30)}[target]
    cert = certify(impl, max_examples=EXAMPLES, seed=SEED, target=target, shrink=False)
    assert cert.passed, cert.summary()


def test_mutation_catalogue_is_large_enough():
    """The issue asks for at least 15 plausible mistakes, each described."""
    assert len(MUTATIONS) >= 15 and all(len(v) > 20 for v in MUTATIONS.values())
