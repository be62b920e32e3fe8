"""The paper's claims registry: every numbered equation is listed, every erratum is backed by a
failing check of the printed form and a passing check of the corrected one, and the checks pass."""

from __future__ import annotations

import pytest

from tstarg.oracles import claim_checks as cc
from tstarg.oracles.claim_checks import deux, quatre, sept, un
from tstarg.oracles.claims import CLAIMS, ERRATA, LABELS, evaluate


def _paper_labels_renamed():
    labels = cc.paper_labels()
    seen, out = set(), []
    for lab in labels:
        out.append("drie12" if lab == "drie5" and lab in seen else lab)
        seen.add(lab)
    return out


def test_registry_covers_every_label():
    """One registry entry per numbered equation of the paper (second drie5 = drie12), no extras, in order."""
    assert list(LABELS) == _paper_labels_renamed()
    assert len(LABELS) == len(set(LABELS)) == 66


@pytest.mark.skipif(cc.paper_path() is None, reason="paper.tex not available (set TSTARG_PAPER)")
def test_embedded_labels_match_paper_source():
    """The embedded copy of the label sequence equals the one parsed from paper.tex."""
    assert cc.paper_labels(cc.paper_path().read_text()) == list(cc.PAPER_LABELS)


def test_statuses_are_well_formed():
    """verified claims name checks; errata name a printed-form check and a correction; definitions a reason."""
    for c in CLAIMS:
        assert c.status in ("verified", "erratum", "not checkable"), c.label
        if c.status == "verified":
            assert c.checks and not c.literal, c.label
        elif c.status == "erratum":
            assert c.checks and c.literal and c.corrected, c.label
        else:
            assert c.reason and not c.checks, c.label
        for name in c.checks + c.literal:
            assert name in cc.CHECKS, (c.label, name)
    assert {c.label for c in ERRATA} >= {"twee1", "twee17", "drie12"}


@pytest.mark.parametrize("claim", ERRATA, ids=lambda c: c.label)
def test_every_erratum_printed_fails_corrected_passes(claim):
    """For each erratum the printed form's check fails and every check of the corrected form passes."""
    for name in claim.literal:
        assert not cc.run_check(name).ok, f"{claim.label}: printed form unexpectedly passes {name}"
    for name in claim.checks:
        o = cc.run_check(name)
        assert o.ok, f"{claim.label}: corrected form fails {name}: {o}"


def test_twee1_frame_erratum():
    """d(gh)/dg at h=e is not the left-invariant frame (O(1) off); d(gh)/dh is (to ~45 digits)."""
    printed, corrected = deux.twee1_frame_printed(), deux.twee1_frame_corrected()
    assert printed.error > 0.1 and not printed.ok
    assert corrected.ok and corrected.error <= corrected.tolerance


def test_twee17_erratum():
    """The chain-rule rate of Gamma = Ad(g)^T gamma matches Omega^b f^a_{b mu} Gamma_a, not the printed sign."""
    printed, corrected = deux.twee17_printed(), deux.twee17_corrected()
    assert printed.error > 0.1 and corrected.error <= corrected.tolerance


def test_een2_index_erratum():
    """The printed translation a^k has the wrong free index; a^i is consistent."""
    assert not un.een2_printed().ok and un.een2_corrected().ok


def test_een3_exact():
    """The transformation rules of F and B in een3 hold exactly for a rational A, F, B."""
    assert un.een3_transformation().ok


@pytest.mark.parametrize("name", [n for n in cc.CHECKS if not n.endswith("_printed")])
def test_claim_checks_pass(name):
    """Every check of a (corrected) claim passes within its stated error model (all sections)."""
    o = cc.run_check(name)
    assert o.ok, f"{name}: {o}"


@pytest.mark.parametrize(
    "alg", ["su(2)", "sl(2,R)", "h(3)", "Bianchi III", "Bianchi VI0", "se(2)", "aff(1)", "R^3"]
)
@pytest.mark.parametrize("seed", [0, 7])
def test_quatre_identities(alg, seed):
    """vier5-vier9 hold exactly (rational arithmetic) for a random cocycle, Upsilon and pi."""
    o = quatre.quatre_identities(alg, seed)
    assert o.ok, o.detail
    assert quatre.vier12_degree(alg, seed).ok


@pytest.mark.parametrize(
    "alg", ["su(2)", "sl(2,R)", "h(3)", "Bianchi III", "Bianchi IV", "se(2)", "aff(1)", "R^3"]
)
def test_zeven1_is_jacobi(alg):
    """zeven1 and the Jacobi identity of drie3 cut out the same space, of dimension dim Z^2 (refimpl)."""
    from tstarg.refimpl import catalogue, cocycle_basis

    o = sept.zeven1_jacobi(alg)
    assert o.ok, o.detail
    dim_z2 = int(o.detail.split("dim Z^2 = ")[1])
    assert dim_z2 == len(cocycle_basis(catalogue(alg), exact=True))


def test_evaluate_has_no_contradiction():
    """The registry's statuses agree with what its checks observe."""
    obs = evaluate()
    assert [o.claim.label for o in obs if o.verdict == "CONTRADICTED"] == []


def test_claims_command_writes_markdown(tmp_path, capsys):
    """`tstarg claims` writes a table with a row for every label and the errata section; also (from
    the shipped index, paper.tex or not) the coverage (items of the paper == entries) and one block per display and
    mathematical sentence, with the errata found among them."""
    from argparse import Namespace

    from tstarg.oracles.paper_index import shipped_index
    from tstarg.reports import cmd_claims as claims

    out = tmp_path / "claims.md"
    rc = claims.main(Namespace(out=str(out), figures=str(tmp_path / "fig"), no_quantum=True))
    text = out.read_text()
    assert rc == 0
    for lab in LABELS:
        assert f"| {lab} |" in text, lab
    assert "## Errata" in text and "twee17" in text.split("## Errata")[1]
    ix = shipped_index()  # the displays and sentences ship with the package: no paper.tex needed
    n = len(ix.displays) + len(ix.sentences)
    assert f"* items: {n}; with a registry entry: {n}; missing: 0" in text
    for d in ix.displays:
        assert f"### {d.id} (" in text, d.id
    for s in ix.sentences:
        assert f"### {s.id}\n" in text, s.id
    assert "sept.d01" in text.split("## Errata among the unlabelled")[1]
    assert f"= {n} items; {n} entries; contradicted []" in capsys.readouterr().out


def test_oracle_checks_all_pass():
    """oracles.oracle_checks.oracle_checks (used by `tstarg verify`) returns passing CheckResults with tolerances stated."""
    from tstarg.oracles.oracle_checks import oracle_checks
    from tstarg.properties.runner import CheckResult

    results = oracle_checks(2, 0)
    assert all(isinstance(r, CheckResult) for r in results)
    assert len({r.name for r in results}) == len(results) >= 10
    failed = {r.name: r.detail for r in results if not r.passed}
    assert not failed, failed
    assert all(r.examples > 0 for r in results)
