"""The paper's LaTeX source (when at hand) and its sequence of equation labels."""

from __future__ import annotations

import os
import re
from pathlib import Path

# The equation labels of paper.tex in order of appearance, as printed (drie5 twice); used when the
# source is not at hand. tests/test_claims.py checks this copy against the file when it is.
PAPER_LABELS = (
    "een1",
    "een2",
    "een3",
    "twee1",
    "twee2",
    "twee3",
    "twee4",
    "twee5",
    "twee6",
    "twee7",
    "twee8",
    "twee9",
    "twee10",
    "twee11",
    "twee12",
    "twee13",
    "twee14",
    "twee15",
    "twee16",
    "twee17",
    "twee18",
    "drie1",
    "drie2",
    "drie3",
    "drie4",
    "drie5",
    "drie6",
    "drie7",
    "drie8",
    "drie9",
    "drie10",
    "drie11",
    "drie5",
    "vier1",
    "vier2",
    "vier3",
    "vier4",
    "vier5",
    "vier6",
    "vier7",
    "vier8",
    "vier9",
    "vier10",
    "vier11",
    "vier12",
    "vier13",
    "vier14",
    "vijf1",
    "vijf2",
    "vijf3",
    "vijf4",
    "vijf5",
    "vijf6",
    "vijf7",
    "vijf8",
    "vijf9",
    "vijf10",
    "vijf11",
    "vijf12",
    "vijf13",
    "vijf14",
    "vijf15",
    "vijf16",
    "zeven1",
    "zeven2",
    "zeven3",
)


def paper_path() -> Path | None:
    """The paper's LaTeX source, needed only to re-index the paper (the index ships with the
    package, :mod:`oracles.paper_index`): ``$TSTARG_PAPER``, else a ``shared/paper.tex`` in a
    folder above the checkout (the authors' layout), else None."""
    repo = Path(__file__).resolve().parents[2]
    cands = [os.environ.get("TSTARG_PAPER")] + [a / "shared" / "paper.tex" for a in repo.parents]
    for c in cands:
        if c and Path(c).is_file():
            return Path(c)
    return None


def paper_labels(text: str | None = None) -> list[str]:
    """Equation labels in order of appearance (section labels excluded: un, deux, ..., sept); from
    ``text``, else the paper's file (:func:`paper_path`), else the embedded :data:`PAPER_LABELS`."""
    if text is None:
        p = paper_path()
        if p is None:
            return list(PAPER_LABELS)
        text = p.read_text()
    labels = re.findall(r"\\label\{([a-z]+[0-9]+)\}", text)
    return labels
