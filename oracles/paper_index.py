"""An index of the paper's LaTeX source: every displayed formula and every mathematical sentence.

The claims registry (``oracles.claims``, ``oracles.claims_unlabelled``) must have one entry per item
listed here; ``tests/test_claims_coverage.py`` enforces it against ``../shared/paper.tex``.

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

import re
from dataclasses import dataclass

__all__ = [
    "ASSERTION_WORDS",
    "Display",
    "PaperIndex",
    "Sentence",
    "index_paper",
    "normalise",
]

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
    displays: tuple[Display, ...]
    sentences: tuple[Sentence, ...]


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
    return PaperIndex(tuple(displays), tuple(sentences))
