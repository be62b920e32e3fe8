"""Declared domains (issue 18, Deliver 1): the certification draws only inside the domain an
implementation declares, says so in the certificate, and checks refusal outside it."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

from tstarg.refimpl import catalogue
from tstarg.reports.certification import Domain, certify, declared_domain
from tstarg.reports.mutants import Plain

SU2 = catalogue("su(2)").f


class Su2NoUpsilon(Plain):
    """The correct Plain restricted to su(2) with Upsilon = 0 and |t| <= 5: refuses the rest."""

    domain: ClassVar[dict] = {
        "algebras": ["su(2)"],
        "upsilon": False,
        "max_abs_t": 5.0,
        "negative_t": True,
    }
    seen: ClassVar[list] = []

    def __init__(self, honest: bool = True):
        super().__init__(None)
        self.honest = honest

    def _guard(self, f, upsilon, t=0.0):
        f, u = np.asarray(f, dtype=float), np.asarray(upsilon, dtype=float)
        self.seen.append((f.shape, bool(np.array_equal(f, SU2)), bool(u.any())))
        if self.honest and (not np.array_equal(f, SU2) or u.any() or abs(t) > 5):
            raise ValueError("outside the declared domain: su(2), Upsilon = 0, |t| <= 5")

    def poisson_tensor(self, f, theta, upsilon, x, pi):
        self._guard(f, upsilon)
        return super().poisson_tensor(f, theta, upsilon, x, pi)

    def hamiltonian_vector_field(self, f, theta, upsilon, *a):
        self._guard(f, upsilon)
        return super().hamiltonian_vector_field(f, theta, upsilon, *a)

    def flow(self, f, theta, upsilon, inertia, potential, x0, pi0, t, steps=None):
        self._guard(f, upsilon, t)
        return super().flow(f, theta, upsilon, inertia, potential, x0, pi0, t, steps)


CHEAP = [
    "poisson_tensor.reference",
    "poisson_tensor.antisymmetry",
    "hamiltonian_vector_field.reference",
    "domain.refusal",
]


def test_draws_only_inside_and_says_so():
    Su2NoUpsilon.seen.clear()
    impl = Su2NoUpsilon()
    cert = certify(impl, max_examples=4, seed=0, shrink=False, checks=[*CHEAP, "flow.long"])
    assert cert.passed, cert.summary()
    assert cert.domain == "su(2), Upsilon = 0, |t| <= 5, t of either sign"
    assert "certified for: su(2), Upsilon = 0, |t| <= 5" in cert.to_markdown()
    refusal = next(c for c in cert.checks if c.name == "domain.refusal")
    assert refusal.examples > 0
    # every call outside su(2) / Upsilon = 0 came from the refusal check (counted there)
    outside = [s for s in Su2NoUpsilon.seen if not s[1] or s[2]]
    assert len(outside) == sum(
        v for k, v in refusal.extra.items() if k.startswith("refused outside")
    )
    assert (
        "poisson_tensor.reference[near_degenerate]" in cert.skipped
    )  # no degenerate set without Upsilon


def test_a_wrong_number_outside_the_domain_fails():
    cert = certify(
        Su2NoUpsilon(honest=False), max_examples=6, seed=0, shrink=False, checks=["domain.refusal"]
    )
    assert not cert.passed and "must raise ValueError" in cert.summary()


@pytest.mark.parametrize(
    ("domain", "match"),
    [
        ([1, 2], "must be a dict"),
        ({"algebras": ["so(17)"]}, "catalogue"),
        ({"theta": "no"}, "True or False"),
        ({"max_abs_t": -1}, "max_abs_t"),
        ({"colour": 1}, "unknown keys"),
    ],
)
def test_malformed_domains_are_named(domain, match):
    class Impl:
        pass

    impl = Impl()
    impl.domain = domain
    with pytest.raises(ValueError, match=match):
        declared_domain(impl)


def test_predicate_domain():
    class Impl:
        domain: ClassVar[dict] = {"algebras": lambda f: f.shape[0] == 3}

    dom = declared_domain(Impl())
    assert (
        dom.admits(SU2)
        and not dom.admits(np.zeros((2, 2, 2)))
        and Domain().admits(np.zeros((1, 1, 1)))
    )
