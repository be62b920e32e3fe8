"""Dogfood: the fast implementation is certified by the same harness third parties use, through
the pytest plugin's fixture (target from --tstarg-impl / TSTARG_IMPL, default refimpl.fast)."""

from __future__ import annotations

import warnings

import pytest

from tstarg.reports.certification import CHECKS, _read_ids, certify


def test_certified(tstarg_certificate):
    assert tstarg_certificate.passed, tstarg_certificate.summary()
    assert tstarg_certificate.checks, "no check ran"


def test_skips_and_xfails_files(tmp_path):
    skips = tmp_path / "skips.txt"
    skips.write_text("poisson_tensor.batch  slow here\nno.such.check\n")
    with pytest.warns(UserWarning, match="unknown check id 'no.such.check'"):
        ids = _read_ids(str(skips), "skips")
    assert ids == {"poisson_tensor.batch": "slow here"}

    class OnlyTensor:
        name, version = "only-tensor", "1"

        def poisson_tensor(self, f, theta, upsilon, x, pi):
            from tstarg.refimpl.fast import implementation

            return implementation.poisson_tensor(f, theta, upsilon, x, pi)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cert = certify(
            OnlyTensor(),
            max_examples=3,
            seed=1,
            skips=ids,
            checks=["poisson_tensor.batch", "hamiltonian_vector_field.reference"],
        )
    assert cert.skipped["poisson_tensor.batch"] == "slow here"
    assert (
        "no method 'hamiltonian_vector_field'" in cert.skipped["hamiltonian_vector_field.reference"]
    )
    assert set(CHECKS) >= set(cert.skipped)


def test_xfail_keeps_the_verdict_green():
    from tstarg.reports.mutants import Plain

    cert = certify(
        Plain("xx_sign"),
        max_examples=5,
        seed=0,
        checks=["poisson_tensor.reference"],
        xfails={"poisson_tensor.reference": "known sign bug"},
        shrink=False,
    )
    assert any(not c.passed for c in cert.checks) and cert.passed


def test_a_rejected_example_is_not_a_failure():
    """A body that draws again (hypothesis.reject) is not failing: it must not start the shrinking
    clock (the check passed all its examples, then stopped at the shrinking budget as a FAIL with
    'UnsatisfiedAssumption' as its reason: seen on flow.reference's work-limit redraws)."""
    import time

    from hypothesis import reject
    from hypothesis import strategies as st

    from tstarg.properties.runner import run_property

    seen = []

    def body(ex):
        seen.append(ex)
        if len(seen) == 1:
            reject()
        time.sleep(0.02)
        return 0.5, None

    res = run_property(
        "rejects once", "-", body, st.integers(0, 100), max_examples=8, seed=0, shrink_seconds=0.01
    )
    assert res.passed and res.examples >= 5, (res.detail, res.examples)
