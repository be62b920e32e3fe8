"""The paper's index ships with the package (oracles/paper_index.json): the claims registry works
without paper.tex, and the shipped file is what a fresh index of the paper gives."""

from __future__ import annotations

import json

import pytest

from tstarg.oracles import claim_checks as cc
from tstarg.oracles import paper_index as pi

PAPER = cc.paper_path()


@pytest.mark.skipif(PAPER is None, reason="paper.tex not found ($TSTARG_PAPER): nothing to compare")
def test_shipped_index_equals_a_fresh_index_of_the_paper():
    """Re-index with `python -m tstarg.oracles.paper_index PAPER.tex` when this fails."""
    fresh = pi.index_paper(PAPER.read_text(encoding="utf-8"))
    shipped = pi.shipped_index()
    assert [d.id for d in shipped.displays] == [d.id for d in fresh.displays]
    assert [s.id for s in shipped.sentences] == [s.id for s in fresh.sentences]
    assert shipped == fresh


def test_shipped_index_is_complete_and_names_the_paper():
    ix = pi.shipped_index()
    assert ix.title.startswith("Modified Symplectic Structures in Cotangent Bundles of Lie Groups")
    labels = [lab for d in ix.displays for lab in d.labels]
    # the printed label sequence (drie5 twice) as embedded in the registry, from an independent regex
    assert labels == list(cc.PAPER_LABELS)
    ids = [d.id for d in ix.displays] + [s.id for s in ix.sentences]
    assert len(ids) == len(set(ids)) and len(ix.displays) > 60 and len(ix.sentences) > 60


def test_write_and_read_back(tmp_path):
    text = (
        r"\title{A {\'e}t\'e paper.}\author{A. B\\ C}\begin{document}\section{One}\label{un}"
        r" The form is closed, $d\omega=0$. \be \label{x1} a=b \ee Done."
        r"\end{document}"
    )
    out = tmp_path / "ix.json"
    assert pi.main([str(_write(tmp_path / "p.tex", text)), str(out)]) == 0
    data = json.loads(out.read_text())
    back = pi.PaperIndex.from_json(data)
    assert back == pi.index_paper(text)
    assert back.title == "A ete paper." and back.authors == "A. B C"
    assert [d.labels for d in back.displays] == [("x1",)]
    assert [s.id for s in back.sentences] == ["un.s01"]


def test_malformed_index_is_a_clear_error():
    with pytest.raises(ValueError, match="paper index: malformed data"):
        pi.PaperIndex.from_json({"title": "t", "authors": "a", "displays": [{"id": "x"}]})


def _write(path, text):
    path.write_text(text)
    return path
