"""An index of the paper's LaTeX source: every displayed formula and every mathematical sentence.

The claims registry (``oracles.claims``, data in ``oracles/registry/``) must have one entry per item
listed here; ``tests/test_claims_coverage.py`` enforces it.

The index ships with the package (``oracles/paper_index.json``, :func:`shipped_index`), so the
registry, ``tstarg claims`` and the tests work without the paper's LaTeX source. The source is
needed only to re-index after the paper changes::

    python -m tstarg.oracles.paper_index PATH/TO/paper.tex   # rewrites oracles/paper_index.json

and ``tests/test_paper_index.py`` checks that the shipped index equals a fresh index of the paper
whenever the source is at hand (``$TSTARG_PAPER``).

Displayed formulas
    Every display environment of the body: ``equation``, ``eqnarray``, ``align``, ``gather``,
    ``multline`` (starred or not, also through the paper's macros ``\\be``, ``\\bea``, ``\\bean``),
    ``\\[ .. \\]`` and ``$$ .. $$``, labelled or not. The id is ``<section>.d<k>``: the section's
    ``\\label`` (``abstract`` before the first section) and the display's order in that section
    (1-based, two digits), e.g. ``sept.d01``. Each carries its printed LaTeX and its ``\\label``s.

Mathematical sentences
    The prose (displays cut out, each display ending a sentence) is split into sentences at a
    full stop followed by white space and a capital letter, a ``$`` or a backslash, never inside
    inline mathematics. A sentence is *mathematical* when it (a) mentions mathematics (inline
    ``$..$`` or an equation ``\\ref``) and (b) asserts a property, i.e. contains one of the words
    of :data:`ASSERTION_WORDS` (closedness, (anti)symmetry, transposition, invertibility,
    polynomial degree, semisimplicity, manifold / variety / plane, invariance, (non)degeneracy,
    symplecticity, (co)cycles and coboundaries, exactness, duality, Darboux coordinates,
    equivalence, implication, consistency, independence, null vectors, solutions, tangency,
    isomorphism, constraints, dimension, dependence, analogy, group actions). The id is ``<section>.s<k>`` in order of appearance.

The rule is mechanical on purpose: a new or edited sentence of that kind changes the index and
the coverage test then names it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = [
    "ASSERTION_WORDS",
    "DATA",
    "Display",
    "PaperIndex",
    "Sentence",
    "index_paper",
    "normalise",
    "shipped_index",
    "write_index",
]

DATA = Path(__file__).with_name("paper_index.json")
"""The shipped index (package data), written by :func:`write_index`."""

_MACROS = {
    r"\be": r"\begin{equation}",
    r"\ee": r"\end{equation}",
    r"\bea": r"\begin{eqnarray}",
    r"\eea": r"\end{eqnarray}",
    r"\bean": r"\begin{eqnarray*}",
    r"\eean": r"\end{eqnarray*}",
}

_ENVS = r"equation|eqnarray|align|gather|multline"

ASSERTION_WORDS = (
    r"closed",
    r"exact",
    r"antisymmetric",
    r"symmetric",
    r"transposed",
    r"inverses?",
    r"determinant",
    r"polynomial",
    r"degree",
    r"semi-?simple",
    r"manifold",
    r"submanifold",
    r"variety",
    r"plane",
    r"invariant",
    r"form-invariant",
    r"degenerate",
    r"non degenerate",
    r"symplectic",
    r"cocycle",
    r"coboundary",
    r"dual",
    r"Darboux",
    r"equivalent",
    r"implies",
    r"follows",
    r"requires",
    r"consistency",
    r"independent",
    r"null",
    r"solutions?",
    r"tangent",
    r"isomorphism",
    r"constrain(?:ed|t)",
    r"dimensional",
    r"obey",
    r"maintained",
    r"related",
    r"trivialisations?",
    r"Whitehead",
    r"determine",
    r"depend",
    r"function of",
    r"analogue",
    r"group action",
)
_ASSERT_RE = re.compile(r"\b(?:" + "|".join(ASSERTION_WORDS) + r")\b", re.IGNORECASE)


@dataclass(frozen=True)
class Display:
    """A displayed formula: ``id`` (``<section>.d<k>``), ``section``, ``env``, ``labels``, ``latex``."""

    id: str
    section: str
    env: str
    labels: tuple[str, ...]
    latex: str


@dataclass(frozen=True)
class Sentence:
    """A mathematical sentence: ``id`` (``<section>.s<k>``), ``section``, ``text`` (normalised LaTeX)."""

    id: str
    section: str
    text: str


@dataclass(frozen=True)
class PaperIndex:
    """The paper's displays and mathematical sentences, with its title and authors as printed
    (LaTeX accents and line breaks removed)."""

    displays: tuple[Display, ...]
    sentences: tuple[Sentence, ...]
    title: str = ""
    authors: str = ""

    def to_json(self) -> dict:
        return {
            "title": self.title,
            "authors": self.authors,
            "displays": [
                {
                    "id": d.id,
                    "section": d.section,
                    "env": d.env,
                    "labels": list(d.labels),
                    "latex": d.latex,
                }
                for d in self.displays
            ],
            "sentences": [
                {"id": t.id, "section": t.section, "text": t.text} for t in self.sentences
            ],
        }

    @classmethod
    def from_json(cls, data: dict) -> "PaperIndex":
        """The inverse of :meth:`to_json`; a malformed file is a ``ValueError`` naming the field."""
        try:
            displays = tuple(
                Display(d["id"], d["section"], d["env"], tuple(d["labels"]), d["latex"])
                for d in data["displays"]
            )
            sentences = tuple(Sentence(t["id"], t["section"], t["text"]) for t in data["sentences"])
            return cls(displays, sentences, str(data["title"]), str(data["authors"]))
        except (KeyError, TypeError) as exc:
            raise ValueError(f"paper index: malformed data ({type(exc).__name__}: {exc})") from None


def normalise(s: str) -> str:
    """Collapse white space (the form in which sentences are stored and quoted)."""
    return re.sub(r"\s+", " ", s).strip()


def _strip_comments(text: str) -> str:
    return re.sub(r"(?<!\\)%[^\n]*", "", text)


def _expand_macros(text: str) -> str:
    # longest names first, and only as whole control words (\bea is not \be + a)
    for name in sorted(_MACROS, key=len, reverse=True):
        text = re.sub(re.escape(name) + r"(?![A-Za-z])", lambda m, r=_MACROS[name]: r, text)
    return text


def _body(text: str) -> str:
    i = text.find(r"\begin{document}")
    j = text.find(r"\begin{thebibliography}")
    return text[i + len(r"\begin{document}") if i >= 0 else 0 : j if j >= 0 else len(text)]


_DISPLAY_RE = re.compile(
    r"\\begin\{(?P<env>(?:" + _ENVS + r")\*?)\}(?P<a>.*?)\\end\{(?P=env)\}"
    r"|\\\[(?P<b>.*?)\\\]"
    r"|\$\$(?P<c>.*?)\$\$",
    re.DOTALL,
)
_SECTION_RE = re.compile(
    r"\\(?:sub)*section\*?\{(?:[^{}]|\{[^{}]*\})*\}(?:\\label\{(?P<lab>[^}]*)\})?"
)


def _section_marks(body: str) -> list[tuple[int, str]]:
    marks = [(0, "abstract")]
    for m in _SECTION_RE.finditer(body):
        if m.group(0).startswith(r"\section") and m.group("lab"):
            marks.append((m.start(), m.group("lab")))
    return marks


def _section_at(marks, pos: int) -> str:
    name = marks[0][1]
    for start, lab in marks:
        if start <= pos:
            name = lab
    return name


_INLINE_RE = re.compile(r"(?<!\\)\$(?:[^$\\]|\\.)+?(?<!\\)\$", re.DOTALL)
_SPLIT_RE = re.compile(r"(?<=\.)\s+(?=[A-Z\\$@])")
_DROP_RE = re.compile(
    r"\\(?:maketitle|appendix|setcounter\{[^}]*\}\{[^}]*\}|begin\{abstract\}|end\{abstract\}|\\)"
)


def _sentences_of(chunk: str) -> list[str]:
    inl: list[str] = []

    def keep(m):
        inl.append(m.group(0))
        return f"@M{len(inl) - 1}@"

    masked = _INLINE_RE.sub(keep, chunk)
    masked = _DROP_RE.sub(" ", masked)
    masked = _SECTION_RE.sub(" ", masked)
    out = []
    for piece in _SPLIT_RE.split(masked):
        piece = re.sub(r"@M(\d+)@", lambda m: inl[int(m.group(1))], piece)
        piece = normalise(piece)
        if piece:
            out.append(piece)
    return out


def _is_mathematical(sentence: str) -> bool:
    has_math = "$" in sentence or r"\ref{" in sentence
    return has_math and bool(_ASSERT_RE.search(sentence))


def _plain(latex: str) -> str:
    r"""A title or author line without LaTeX: accents ``\'{\i}`` -> i, ``\\`` -> space."""
    t = re.sub(r"\\\\", " ", latex)
    t = re.sub(r"\\['`^\"~]\{?\\?([A-Za-z])\}?", r"\1", t)
    t = re.sub(r"[{}]", "", t)
    return normalise(t)


def _front_matter(text: str) -> tuple[str, str]:
    """The ``\\title`` and ``\\author`` of the LaTeX source (empty when absent)."""

    def arg(cmd: str) -> str:
        m = re.search(r"\\" + cmd + r"\{((?:[^{}]|\{[^{}]*\})*)\}", _strip_comments(text))
        return _plain(m.group(1)) if m else ""

    return arg("title"), arg("author")


def index_paper(text: str) -> PaperIndex:
    """Parse the paper's LaTeX ``text`` into its displays and mathematical sentences (see module doc)."""
    body = _expand_macros(_strip_comments(_body(text)))
    marks = _section_marks(body)
    displays: list[Display] = []
    counts: dict[str, int] = {}
    chunks: list[tuple[str, str]] = []  # (section, prose) between displays and section marks
    pos = 0
    cuts = sorted(
        [(m.start(), m.end(), m) for m in _DISPLAY_RE.finditer(body)]
        + [(s, s, None) for s, _ in marks[1:]]
    )
    for start, end, m in cuts:
        chunks.append((_section_at(marks, pos), body[pos:start]))
        pos = end
        if m is None:
            continue
        sec = _section_at(marks, start)
        counts[sec] = counts.get(sec, 0) + 1
        env = m.group("env") or ("\\[\\]" if m.group("b") is not None else "$$")
        latex = m.group("a") if m.group("env") else (m.group("b") or m.group("c") or "")
        labels = tuple(re.findall(r"\\label\{([^}]*)\}", latex))
        displays.append(Display(f"{sec}.d{counts[sec]:02d}", sec, env, labels, latex.strip()))
    chunks.append((_section_at(marks, pos), body[pos:]))
    sentences: list[Sentence] = []
    scount: dict[str, int] = {}
    for sec, prose in chunks:
        for s in _sentences_of(prose):
            if _is_mathematical(s):
                scount[sec] = scount.get(sec, 0) + 1
                sentences.append(Sentence(f"{sec}.s{scount[sec]:02d}", sec, s))
    title, authors = _front_matter(text)
    return PaperIndex(tuple(displays), tuple(sentences), title, authors)


@functools.lru_cache(maxsize=1)
def shipped_index() -> PaperIndex:
    """The index shipped with the package (:data:`DATA`): what the registry is checked against."""
    try:
        data = json.loads(DATA.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ValueError(f"paper index {DATA}: cannot be read ({exc})") from None
    return PaperIndex.from_json(data)


def write_index(text: str, path: Path = DATA) -> PaperIndex:
    """Index the LaTeX ``text`` and write it to ``path`` (default: the shipped :data:`DATA`),
    with the SHA-256 of the source it came from."""
    index = index_paper(text)
    data = {
        "source_sha256": hashlib.sha256(text.encode("utf-8")).hexdigest(),
        "written_by": "python -m tstarg.oracles.paper_index PAPER.tex",
        **index.to_json(),
    }
    Path(path).write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    shipped_index.cache_clear()
    return index


def main(argv: list[str] | None = None) -> int:
    """``python -m tstarg.oracles.paper_index PAPER.tex [OUT.json]``: re-index the paper."""
    argv = sys.argv[1:] if argv is None else argv
    if not 1 <= len(argv) <= 2:
        print("usage: python -m tstarg.oracles.paper_index PAPER.tex [OUT.json]", file=sys.stderr)
        return 2
    out = Path(argv[1]) if len(argv) == 2 else DATA
    ix = write_index(Path(argv[0]).read_text(encoding="utf-8"), out)
    print(f"{out}: {len(ix.displays)} displays, {len(ix.sentences)} mathematical sentences")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
