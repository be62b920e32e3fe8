"""Flow-only implementations get the whole battery, on the group they live on, at times spread up
to the certified |t| (issue 26: false PASSes of integrators).

* ``protocol.inputs`` and ``domain.refusal`` run through ``flow`` (a client declaring the su(2)-only
  domain that never refuses is rejected, through the command line too);
* su(2) flows are judged on SU(2) (the default group): a correct SO(3) flow (``x = log_SO(3)``)
  passes when it declares ``group = "SO(3)"`` and is rejected with the reason when it does not;
* ``flow.long`` judges every example at the reach of its model (``|t|`` up to 10): a flow accurate
  to ``|t| = 5`` and loose beyond is rejected; draws cover ``|x(t)| > pi`` and both signs.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tstarg.refimpl import su2
from tstarg.reports.certification import FLOW_T_MAX, REGISTRY, Domain, certify, reference_work
from tstarg.reports.certification._common import LONG_WORK_LIMIT
from tstarg.reports.certification.checks.flow_long import FlowLongExample, LooseAfter, SO3Flow
from tstarg.reports.certification.models import Hamiltonian
from tstarg.reports.cli import main

from .meta.flow_only import FlowOnly


def _spinning_top():
    """su(2), I = 1, x0 = 0, pi0 = (0, 0, 4) (the issue's example) judged at t = 1 (and at the
    model's reach): x(t) = (0, 0, 4 t) on SU(2) (|x| < 2 pi), a rotation by 4 rad about e_3, where
    SO(3)'s logarithm is (0, 0, 4 - 2 pi) = (0, 0, -2.283), the other sheet."""
    f = su2().f
    z = np.zeros((3, 3))
    x0, pi0 = np.zeros(3), np.array([0.0, 0.0, 4.0])
    reach = min(
        FLOW_T_MAX, LONG_WORK_LIMIT / (reference_work(f, z, z, np.eye(3), None, x0, pi0, 1.0) / 27)
    )
    model = ("su(2)", f, z, z, x0, pi0)
    return FlowLongExample(Hamiltonian(model, np.eye(3), None), 1.0 / reach, 1.0)


def _body(impl):
    body, _ = REGISTRY["flow.long"].build(impl, Domain(), {})
    return body


def test_so3_flow_passes_declared_and_is_rejected_undeclared_with_the_reason():
    """Independent fact: on the free symmetric top x(t) = (0, 0, 4 t), |x| = 4 t passes pi at
    t = pi / 4, where SO(3)'s principal logarithm jumps to the other SU(2) sheet."""
    ex = _spinning_top()
    ratio, _ = _body(SO3Flow(declare=True))(ex)
    assert ratio <= 1.0
    with pytest.raises(AssertionError, match=r"must declare it: group = 'SO\(3\)'") as info:
        _body(SO3Flow(declare=False))(ex)
    assert "SU(2)" in str(info.value) and "right up to Ad(g)" in str(info.value)
    assert "flow at t = 1:" in str(info.value)
    cert = certify(SO3Flow(declare=True), max_examples=2, seed=0, checks=["flow.long"])
    assert cert.passed and cert.group.startswith("SO(3)"), cert.summary()
    assert "group: SO(3)" in cert.summary()


def test_default_group_is_named_su2():
    cert = certify(FlowOnly(), max_examples=1, seed=0, checks=["flow.long"])
    assert "SU(2) (spin-1/2" in cert.group


def test_loose_after_t5_is_rejected_at_the_reach_with_every_field_labelled():
    cert = certify(LooseAfter(), max_examples=5, seed=0, checks=["flow.long"], shrink=False)
    assert not cert.passed
    (check,) = cert.checks
    t = float(check.detail.split("flow at t = ")[1].split(":")[0])
    assert abs(t) > 5, check.detail
    text = check.falsifying_example
    for label in ("algebra = ", "x = ", "pi = ", "inertia = ", "potential = "):
        assert label in text, text
    assert "fraction_of_reach = " in text and "sign_of_t = " in text


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_flow_long_draws_cover_the_certified_range(seed):
    """15 examples (the ci profile's default): |t| near T = 10, both signs, |x(t)| > pi on su(2)."""
    cert = certify(FlowOnly(), max_examples=15, seed=seed, checks=["flow.long"], shrink=False)
    assert cert.passed, cert.summary()
    (c,) = cert.checks
    assert c.examples >= 15
    assert c.extra["largest |t| judged"] >= 9.0
    assert c.extra["negative t judged"] >= 1
    assert c.extra.get("su(2): |x(t)| > pi judged", 0) >= 1, c.extra


def test_flow_only_gets_inputs_and_domain_checks_through_the_command_line(tmp_path):
    """The command line used to skip protocol.inputs and domain.refusal for want of
    poisson_tensor: a flow-only client declaring su(2) that never refuses passed."""
    out = tmp_path / "cert"
    argv = ["certify", "tests.meta.flow_only:domain_ignored", "--max-examples", "3"]
    argv += ["--workers", "1", "--check", "domain.refusal", "--check", "protocol.inputs"]
    assert main([*argv, "--verdict-only", "--out", str(out)]) == 1
    data = json.loads((out / "certificate.json").read_text())
    ran = {c["name"]: c for c in data["checks"]}
    assert "domain.refusal" in ran and not ran["domain.refusal"]["passed"], data
    assert "protocol.inputs" in ran and ran["protocol.inputs"]["examples"] > 0, data
    assert "domain.refusal" not in data["skipped"] and "protocol.inputs" not in data["skipped"]


def test_verdict_is_printed_before_shrinking_and_the_example_says_if_minimal(tmp_path, capfd):
    out = tmp_path / "cert"
    argv = ["certify", "tests.meta.flow_only:loose_after_5", "--check", "flow.long"]
    argv += ["--max-examples", "4", "--workers", "1", "--shrink-seconds", "5"]
    assert main([*argv, "--out", str(out)]) == 1
    text = capfd.readouterr().out
    first = text.index("verdict FAIL: flow.long found a failing example")
    assert first < text.index("certificate for ")
    assert "shrinking it (at most 5 s)" in text
    assert "example shown: minimal" in text or "example shown: not minimal" in text


def test_verdict_only_does_not_announce_a_shrink(tmp_path, capfd):
    """--verdict-only stops at the first failing example: the verdict line used to say "shrinking
    it" there too (a newcomer waited for a shrink that never came)."""
    out = tmp_path / "cert"
    argv = ["certify", "tests.meta.flow_only:loose_after_5", "--check", "flow.long"]
    argv += ["--max-examples", "4", "--workers", "1", "--verdict-only"]
    assert main([*argv, "--out", str(out)]) == 1
    text = capfd.readouterr().out
    assert "verdict FAIL: flow.long found a failing example" in text, text
    assert "shrinking it" not in text, text
    assert "not shrunk" in text, text


def test_declared_adjoint_on_an_algebra_with_a_centre_says_it_is_set_aside():
    """Ad(g) is not faithful where the algebra has a centre (h(3): Ad(exp(z e_3)) = 1 for every z),
    so a declared "adjoint" is set aside there; the group's name and the certificate's description
    used to say "the adjoint group Ad(G) (declared)" all the same."""
    from tstarg.refimpl import catalogue
    from tstarg.reports.certification.group import describe_group, group_for

    h3 = np.asarray(catalogue("h(3)").f, dtype=float)
    g = group_for("adjoint", h3)
    assert g is not None and "set aside" in g.name, g.name
    # the judged group is faithful: a central element (ad_z = 0) moves it, unlike Ad
    z = np.zeros(3)
    z[[a for a in range(3) if not np.any(h3[:, a, :])][0]] = 1.0
    assert not np.any(np.einsum("a,mab->mb", z, h3))
    assert np.max(np.abs(g.exp(z) - np.eye(g.dim))) > 0.5
    su3 = np.asarray(catalogue("su(3)").f, dtype=float)
    assert "set aside" not in group_for("adjoint", su3).name
    assert "set aside" in describe_group("adjoint")
