"""Every displayed formula and every mathematical sentence of the paper has a registry entry, each
entry's status is backed by its checks, and every erratum found among them has a failing check of
the printed form and a passing check of the corrected one."""

from __future__ import annotations

from argparse import Namespace

import pytest
import sympy as sp

from tstarg.oracles import claim_checks as cc
from tstarg.oracles.claim_checks import algebras, sept
from tstarg.oracles.claims import (
    LABELS,
    SENTENCES,
    STATUSES,
    UNLABELLED,
    coverage,
    entries_for,
    evaluate_entries,
)
from tstarg.oracles.paper_index import index_paper, shipped_index

PAPER = cc.paper_path()
needs_paper = pytest.mark.skipif(PAPER is None, reason="paper.tex not found (set TSTARG_PAPER)")


@pytest.fixture(scope="module")
def index():
    """The paper's index as shipped with the package (tests/test_paper_index.py checks it equals
    a fresh index of paper.tex whenever the source is at hand)."""
    return shipped_index()


# ------------------------------------------------------------------ coverage of the real paper
def test_every_item_of_the_paper_has_an_entry(index):
    """Displays (labelled or not) and mathematical sentences in the paper == entries: none missing,
    none anchored to text that is not there, none naming an item the paper does not have."""
    cov = coverage(index)
    assert cov["missing"] == [], f"paper items without a registry entry: {cov['missing']}"
    assert cov["misanchored"] == [], (
        f"entries whose quote is not in their item: {cov['misanchored']}"
    )
    assert cov["extra"] == [], f"entries for items the paper does not have: {cov['extra']}"
    assert cov["entries"] == cov["items"] == len(index.displays) + len(index.sentences)


@needs_paper
def test_index_finds_every_label_and_every_display_kind(index):
    """The displays carry exactly the paper's \\label sequence (an independent regex over the file),
    and the index sees every kind of display the paper uses."""
    labels = [lab for d in index.displays for lab in d.labels]
    assert labels == cc.paper_labels(PAPER.read_text())
    envs = {d.env for d in index.displays}
    assert {"equation", "eqnarray", "eqnarray*", "\\[\\]"} <= envs
    # each display's printed LaTeX is a substring of the source once the macros are expanded
    src = PAPER.read_text()
    for d in index.displays:
        assert d.latex.splitlines()[0].strip() in src, d.id
    # ids are unique and ordered within each section
    ids = [d.id for d in index.displays] + [s.id for s in index.sentences]
    assert len(ids) == len(set(ids))


def test_issue_sentences_are_indexed(index):
    """The sentences the issue names are among the mathematical sentences."""
    text = " ".join(s.text for s in index.sentences)
    for phrase in (
        "is a polynomial in $\\pi^L$ of degree at most equal to $N$",
        "For a semisimple Lie algebra",
        "obviously closed",
        "They are mutually transposed",
        "is an algebraic manifold",
        "Following the GNH algorithm",
        "Two independent null vectors",
        "Consistency requires",
    ):
        assert phrase in text, phrase


def test_labelled_registry_is_used_for_labelled_displays():
    """Labelled displays take their entry from the labelled registry (66 labels, drie12 included)."""
    ix = shipped_index()
    pairs = [(item, e) for item, e in entries_for(ix) if getattr(item, "labels", ())]
    got = [lab for _, e in pairs for lab in e.labels]
    assert got == list(LABELS)
    for item, e in pairs:
        assert e.status in STATUSES, item.id
        if e.status == "erratum":
            assert e.literal and e.corrected and e.checks, item.id
        elif e.status == "verified":
            assert e.checks and not e.literal, item.id
        else:
            assert e.reason, item.id
    by_id = {item.id: e for item, e in pairs}
    assert by_id["quatre.d11"].attained and "vier12_degree_attained" in by_id["quatre.d11"].checks
    assert "semisimple_needed_counterexample" in by_id["sept.d05"].checks


# ------------------------------------------------------------------ the coverage test can fail
_MINI = r"""
\documentstyle{article}
\def\be{\begin{equation}}
\def\ee{\end{equation}}
\def\bean{\begin{eqnarray*}}
\def\eean{\end{eqnarray*}}
\begin{document}
\section{First}\label{un}
Text with $a.b$ inline. The form $\omega$ is closed and $x=1$.
\be\label{een1} a = b \ee
Not a claim here. Then
\[ c = d \]
and also $$ e = f $$ then
\bean g &=& h \eean
\section{Second}\label{deux}
The matrix $M$ is antisymmetric.
\begin{align*} u = v \end{align*}
\begin{thebibliography}{9}\bibitem{x} $X$ is closed.\end{thebibliography}
\end{document}
"""


def test_parser_on_a_synthetic_paper():
    """Macros, \\[..\\], $$..$$, starred environments, section ids, sentences split outside inline
    mathematics, the assertion rule, and the bibliography left out."""
    ix = index_paper(_MINI)
    assert [(d.id, d.env, d.labels) for d in ix.displays] == [
        ("un.d01", "equation", ("een1",)),
        ("un.d02", "\\[\\]", ()),
        ("un.d03", "$$", ()),
        ("un.d04", "eqnarray*", ()),
        ("deux.d01", "align*", ()),
    ]
    assert [d.latex for d in ix.displays][1:] == ["c = d", "e = f", "g &=& h", "u = v"]
    assert [(s.id, s.text) for s in ix.sentences] == [
        ("un.s01", "The form $\\omega$ is closed and $x=1$."),
        ("deux.s01", "The matrix $M$ is antisymmetric."),
    ]


@needs_paper
def test_coverage_fails_for_a_new_display_or_sentence(index):
    """An extra unlabelled display or an extra mathematical sentence in the paper is reported
    as missing (the registry would have to grow)."""
    src = PAPER.read_text()
    anchor = r"\section{Conclusions}"
    assert anchor in src
    extra_display = src.replace(anchor, "\\[ \\Delta = 0 \\]\n" + anchor)
    cov = coverage(index_paper(extra_display))
    assert cov["missing"] == [f"cinq.d{sum(d.section == 'cinq' for d in index.displays) + 1:02d}"]
    extra_sentence = src.replace(anchor, "Hence $\\omega_L$ is closed.\n" + anchor)
    cov = coverage(index_paper(extra_sentence))
    assert cov["missing"] == [f"cinq.s{sum(s.section == 'cinq' for s in index.sentences) + 1:02d}"]
    edited = src.replace("They are mutually transposed", "They are transposed of each other")
    assert coverage(index_paper(edited))["misanchored"] == ["quatre.s02"]


# ------------------------------------------------------------------ entries and their checks
@pytest.mark.parametrize("entry", UNLABELLED + SENTENCES, ids=lambda e: e.id)
def test_entries_are_well_formed(entry):
    """A status from the list; errata name a printed-form check, a correction and corrected-form
    checks; restrictions state the hypothesis and its counterexample; definitions and
    not-checkable entries say why or show consistency; every named check exists."""
    assert entry.status in STATUSES
    for name in entry.checks + entry.literal:
        assert name in cc.CHECKS, (entry.id, name)
    if entry.status == "erratum":
        assert entry.checks and entry.literal and entry.corrected
    elif entry.status == "restriction":
        assert entry.checks and entry.corrected and entry.needed
    elif entry.status == "verified":
        assert entry.checks and not entry.literal and entry.evidence
    elif entry.status == "not checkable":
        assert entry.reason and not entry.checks
    else:
        assert entry.reason or entry.checks


ERRATA = [e for e in UNLABELLED + SENTENCES if e.status == "erratum"]


def test_the_new_errata():
    """Among the unlabelled formulas the appendix component form of delta_1 (sept.d01) and the
    right-handed half of the trivialisations (deux.d02) are errata, and the sentence on xi (sept.s11)."""
    assert {e.id for e in ERRATA} == {"sept.d01", "deux.d02", "sept.s11"}


@pytest.mark.parametrize("entry", ERRATA, ids=lambda e: e.id)
def test_errata_printed_fails_corrected_passes(entry):
    for name in entry.literal:
        assert not cc.run_check(name).ok, f"{entry.id}: printed form unexpectedly passes {name}"
    for name in entry.checks:
        o = cc.run_check(name)
        assert o.ok, f"{entry.id}: corrected form fails {name}: {o}"


def test_delta1_component_erratum_exact():
    """sept.d01 by hand on su(2): for the cocycle theta(u) = k(u) eta (antisymmetric), the printed
    component form gives a nonzero coboundary, the corrected form zero; the first row agrees with
    the definition k(u) = -ad(u)^T; the corrected last term is theta_{alpha,k}."""
    F = algebras.structure_constants("su(2)")
    th = sept._su2_coboundary_theta(F)
    assert th + th.T == sp.zeros(3, 3) and th != sp.zeros(3, 3)
    printed = sept._delta1_components(F, th, "printed")
    corrected = sept._delta1_components(F, th, "corrected")
    definition = sept._delta1_components(F, th, "definition")
    assert all(v == 0 for v in corrected.values()) and all(v == 0 for v in definition.values())
    assert any(v != 0 for v in printed.values())
    # mu = 0, nu = 1, alpha = 0: printed -theta_{k,0} f^k_01 = -theta_{2,0}; corrected -theta_{0,2}
    assert printed[(0, 1, 0)] - corrected[(0, 1, 0)] == -th[2, 0] + th[0, 2] != 0


def test_degree_bound_and_hypotheses():
    """Delta's degree: attained on aff(1) (N = 2), not for odd N; semisimplicity: h(3) needs it,
    aff(1) shows it is not necessary; closedness needs the cocycle condition."""
    o = cc.run_check("vier12_degree_attained")
    assert o.ok and "aff(1): N = 2, degree 2" in o.detail and "su(2): N = 3, degree 2" in o.detail
    o = cc.run_check("semisimple_needed_counterexample")
    assert o.ok and "dim H^2(h(3)) = 2" in o.detail and "aff(1) (solvable): dim H^2 = 0" in o.detail
    assert cc.run_check("cocycle_needed_counterexample").ok


def test_structure_constants_satisfy_jacobi():
    for name in algebras.ALGEBRAS:
        assert sept._jacobi_ok(algebras.structure_constants(name)), name
    # [e1, e2] = e1, [e2, e3] = e2: the Jacobiator of (e1, e2, e3) is e1
    assert not sept._jacobi_ok(algebras.from_brackets(3, {(0, 1): {0: 1}, (1, 2): {1: 1}}))
    with pytest.raises(ValueError, match="unknown algebra"):
        algebras.structure_constants("e8")


@needs_paper
def test_entries_observations_agree_with_statuses(index):
    obs = evaluate_entries(index)
    assert [o.item.id for o in obs if o.verdict == "CONTRADICTED"] == []
    assert len(obs) == len(index.displays) + len(index.sentences)


@pytest.mark.slow
@needs_paper
def test_claims_report_is_deterministic(tmp_path):
    """Two runs with fresh check caches write the same claims.md (no run-to-run numbers)."""
    from tstarg.reports import cmd_claims

    texts = []
    for k in range(2):
        cc.clear_cache()
        out = tmp_path / f"c{k}.md"
        cmd_claims.main(Namespace(out=str(out), figures=str(tmp_path / "f"), no_quantum=True))
        texts.append(out.read_text())
    assert texts[0] == texts[1]
