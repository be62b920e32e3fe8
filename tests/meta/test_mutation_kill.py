"""Test the tests: the certification battery rejects every deliberately broken implementation
(reports/mutants.py) and accepts the correct ones. The kill rate is the fraction rejected.

A mutant listed in ``MUTANT_CHECKS`` is certified on the one clause it is planted against
(so each clause is shown to reject it by itself); the others run the whole battery."""

from __future__ import annotations

from typing import ClassVar

import pytest

from tstarg.reports.certification import MUTANT_CHECKS, MUTATIONS, certify
from tstarg.reports.certification.registry import mutant
from tstarg.reports.mutants import Plain

SEED = 0
EXAMPLES = 10


SLOW = {
    "centre_lost",
    "energy_dissipation",
    "flow.drift",
    "flow.long",
    "flow.reference",
    "plain",
}  # 25-70 s each on a loaded machine (flow.reference: the plain RK4 on k examples)


def _params(names):
    return [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n for n in names]


@pytest.mark.parametrize("mutation", _params(sorted(MUTATIONS)))
def test_certify_rejects_mutant(mutation):
    impl = mutant(mutation)
    cert = certify(
        impl,
        max_examples=EXAMPLES,
        seed=SEED,
        target=f"tstarg.reports.mutants:Plain({mutation!r})",
        checks=MUTANT_CHECKS.get(mutation),
        stop_on_failure=True,
        shrink=False,
    )
    assert cert.checks, cert.summary()
    assert not cert.passed, (
        f"mutation {mutation!r} ({MUTATIONS[mutation]}) survived:\n{cert.summary()}"
    )


@pytest.mark.parametrize(
    "clause", _params(sorted({c for cs in MUTANT_CHECKS.values() for c in cs}))
)
def test_correct_plain_passes_each_planted_clause(clause):
    """The clause that kills a planted mutant accepts the correct implementation (same budget)."""
    from tstarg.refimpl.fast import implementation as fast

    impl = Plain(None)
    if clause == "flow.poisson_map":
        impl = _FastPoisson(fast)
    if clause == "domain.refusal":
        impl = _Su2Only()
    cert = certify(
        impl, max_examples=EXAMPLES, seed=SEED, target="plain", checks=[clause], shrink=False
    )
    assert cert.checks and cert.passed, cert.summary()


class _FastPoisson:
    """The fast flow (accurate to 1e-10, hence a Poisson map to that accuracy) declared a Poisson
    integrator; ``steps`` is accepted and ignored."""

    name, version, poisson_integrator = "fast-as-poisson", "test", True

    def __init__(self, fast):
        self._fast = fast

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t, steps=None):
        return self._fast.flow(f, theta, upsilon, inertia, potential, x0, pi0, t)


class _Su2Only(Plain):
    """The correct Plain restricted to su(2), refusing everything else."""

    domain: ClassVar[dict] = {"algebras": ["su(2)"]}

    def __init__(self):
        super().__init__(None)

    def _guard(self, f):
        import numpy as np

        from tstarg.refimpl import catalogue

        if not np.array_equal(np.asarray(f, dtype=float), catalogue("su(2)").f):
            raise ValueError("only su(2) is supported")

    def poisson_tensor(self, f, *a):
        self._guard(f)
        return super().poisson_tensor(f, *a)

    def hamiltonian_vector_field(self, f, *a):
        self._guard(f)
        return super().hamiltonian_vector_field(f, *a)

    def flow(self, f, *a, **kw):
        self._guard(f)
        return super().flow(f, *a, **kw)


@pytest.mark.parametrize("target", _params(["plain", "fast", "reference"]))
def test_certify_accepts_correct_implementations(target):
    from tstarg.refimpl.fast import implementation as fast
    from tstarg.refimpl.reference import Reference

    impl = {"plain": Plain(None), "fast": fast, "reference": Reference(30)}[target]
    checks = (
        None
        if target != "reference"
        else [
            c
            for c in (
                "poisson_tensor.reference",
                "poisson_tensor.antisymmetry",
                "hamiltonian_vector_field.reference",
            )
        ]
    )
    cert = certify(
        impl,
        max_examples=EXAMPLES if target != "plain" else 5,
        seed=SEED,
        target=target,
        shrink=False,
        checks=checks,
    )
    assert cert.passed, cert.summary()


def test_every_check_has_teeth_or_says_why_not():
    """Each check of the registry names the planted mutants it rejects by itself, except the two
    whose mistakes need a whole battery to show (their mutants run the whole battery)."""
    from tstarg.reports.certification import REGISTRY

    bare = {cid for cid, c in REGISTRY.items() if not c.mutants}
    assert bare <= {"poisson_tensor.degenerate", "hamiltonian_vector_field.reference"}, bare
    assert {"degenerate_garbage", "pidot_s_sign", "xdot_no_frame"} <= set(MUTATIONS)


def test_mutation_catalogue_is_large_enough():
    """The issue asks for at least 15 plausible mistakes, each described, and one per new clause."""
    assert len(MUTATIONS) >= 15 and all(len(v) > 20 for v in MUTATIONS.values())
    clauses = {c for cs in MUTANT_CHECKS.values() for c in cs}
    assert {
        "protocol.inputs",
        "poisson_tensor.batch",
        "flow.long",
        "flow.order",
        "flow.drift",
        "flow.poisson_map",
        "domain.refusal",
        "poisson_tensor.antisymmetry",
    } <= clauses
    # issue 26's false PASS classes, each planted against the clause that now rejects it
    assert MUTANT_CHECKS["so3_undeclared"] == ["flow.long"]
    assert MUTANT_CHECKS["loose_after_5"] == ["flow.long"]
    assert MUTANT_CHECKS["domain_ignored_flow_only"] == ["domain.refusal"]
