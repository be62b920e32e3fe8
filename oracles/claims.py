"""The registry of the paper's claims: every numbered equation, every unlabelled display and every
mathematical sentence, with its status, its checks and its errata.

The data live in package files, one per section of the paper, ``oracles/registry/<section>.toml``
(``abstract``, ``un``, ``deux``, ``trois``, ``quatre``, ``cinq``, ``six``, ``sept``), each an array
``[[claim]]`` of tables, read with :mod:`tomllib` and validated on load (:func:`load_registry`; a
bad file raises :class:`RegistryError` naming the file, the entry and the field). One entry type,
:class:`Claim`, serves all three kinds:

* a numbered equation has a ``label`` (the paper's ``\\label``; the second ``drie5`` is called
  ``drie12``) and a ``method`` (``symbolic``, ``numeric``, ``both`` or ``-``); the labels appear in
  the files in the paper's order (:data:`LABELS`);
* an unlabelled display (``<section>.d<k>``) or a mathematical sentence (``<section>.s<k>``) has an
  ``id`` from :mod:`oracles.paper_index` and a ``quote`` that anchors it to the printed text (it
  must occur in the display's LaTeX or in the sentence, white space collapsed).

Fields: ``claim`` (what is claimed), ``status``, ``checks`` (checks of :mod:`oracles.claim_checks`
that must PASS), ``literal`` (checks of the printed form that must FAIL), ``tests`` (pytest tests),
``corrected`` (the correction of an erratum or the hypothesis of a restriction, with its evidence),
``reason`` (why not checkable), ``remark``, ``evidence`` (precision, algebras), ``attained`` (a bound
is attained), ``needed`` (a hypothesis is needed, with the example), ``labels`` (the numbered
equations an unlabelled item repeats or inherits from), ``hypothesis_checks`` (of a numbered
equation: the checks of ``attained``/``needed``, run with its display's entry).

Statuses
    ``verified`` (the checks pass), ``erratum`` (the ``literal`` checks FAIL and the ``checks`` of
    the corrected form pass), ``restriction`` (true only under a hypothesis the text does not state;
    ``corrected`` states it, the checks show both the restricted claim and the counterexample),
    ``definition`` (a definition or notation; checks, if any, show it is consistent) and
    ``not checkable`` (``reason`` says why). A numbered equation is ``verified``, ``erratum`` or
    ``not checkable``.

:func:`evaluate` runs the checks of the numbered equations and :func:`evaluate_entries` those of
every display and sentence of the paper's index; an observation that contradicts the recorded status
is reported as ``CONTRADICTED``. :func:`coverage` compares the registry with the paper's index.
"""

from __future__ import annotations

import time
import tomllib
from collections import Counter
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

from .claim_checks import CHECKS, Outcome, run_check
from .paper_index import PaperIndex, normalise

__all__ = [
    "CLAIMS",
    "ERRATA",
    "LABELS",
    "REGISTRY",
    "REGISTRY_DIR",
    "SECTION_FILES",
    "SENTENCES",
    "STATUSES",
    "UNLABELLED",
    "Claim",
    "RegistryError",
    "coverage",
    "entries_for",
    "evaluate",
    "evaluate_entries",
    "fmt_outcome",
    "labelled_display_entry",
    "load_registry",
    "render_entries_markdown",
    "render_markdown",
]

STATUSES = ("verified", "erratum", "restriction", "definition", "not checkable")
LABEL_STATUSES = ("verified", "erratum", "not checkable")
METHODS = ("symbolic", "numeric", "both", "-")
SECTION_FILES = ("abstract", "un", "deux", "trois", "quatre", "cinq", "six", "sept")
"""The registry's files in the paper's order (``oracles/registry/<name>.toml``)."""
REGISTRY_DIR = Path(__file__).with_name("registry")


@dataclass(frozen=True)
class Claim:
    """One registry entry: a numbered equation (``label`` set, ``id`` equal to it) or an unlabelled
    display or sentence (``label`` None); the fields are described in the module docstring."""

    id: str
    section: str
    claim: str
    status: str
    label: str | None = None
    method: str = ""
    quote: str = ""
    checks: tuple = ()
    literal: tuple = ()
    tests: tuple = ()
    corrected: str = ""
    reason: str = ""
    remark: str = ""
    evidence: str = ""
    attained: str = ""
    needed: str = ""
    labels: tuple = ()
    hypothesis_checks: tuple = ()


class RegistryError(ValueError):
    """A registry file breaks a rule of the format (the message names the file, the entry, the field)."""


_TUPLES = {f.name for f in fields(Claim) if f.type == "tuple"}
_STRINGS = {f.name for f in fields(Claim) if f.type == "str"} - {"id", "section"}
_KEYS = _TUPLES | _STRINGS | {"id", "label"}


def _entry(path: Path, k: int, raw: object, section: str, known_checks) -> Claim:
    where = f"{path.name}: claim #{k + 1}"
    if not isinstance(raw, dict):
        raise RegistryError(f"{where}: a [[claim]] table expected, got {type(raw).__name__}")
    has_label, has_id = "label" in raw, "id" in raw
    if has_label == has_id:
        raise RegistryError(
            f"{where}: exactly one of 'label' (a numbered equation) or 'id' (an "
            f"unlabelled display or sentence) is required"
        )
    key = raw["label"] if has_label else raw["id"]
    if not isinstance(key, str) or not key:
        raise RegistryError(
            f"{where}: field {'label' if has_label else 'id'!r} must be a non-empty string"
        )
    where = f"{path.name}: claim {key!r}"
    unknown = sorted(set(raw) - _KEYS)
    if unknown:
        raise RegistryError(f"{where}: unknown field(s) {unknown}; known: {sorted(_KEYS)}")
    for name in ("claim", "status"):
        if name not in raw:
            raise RegistryError(f"{where}: field {name!r} is required")
    kw = {}
    for name, value in raw.items():
        if name in ("id", "label"):
            continue
        if name in _TUPLES:
            if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
                raise RegistryError(f"{where}: field {name!r} must be a list of non-empty strings")
            kw[name] = tuple(value)
        elif not isinstance(value, str):
            raise RegistryError(
                f"{where}: field {name!r} must be a string, got {type(value).__name__}"
            )
        else:
            kw[name] = value
    c = Claim(id=key, section=section, label=key if has_label else None, **kw)
    allowed = LABEL_STATUSES if has_label else STATUSES
    if c.status not in allowed:
        raise RegistryError(f"{where}: field 'status' is {c.status!r}; allowed: {list(allowed)}")
    if has_label:
        if c.method not in METHODS:
            raise RegistryError(
                f"{where}: field 'method' is {c.method!r}; allowed: {list(METHODS)}"
            )
        if c.quote:
            raise RegistryError(
                f"{where}: field 'quote' is for unlabelled items (a label anchors itself)"
            )
    else:
        if not c.id.startswith(section + ".") or not c.quote:
            raise RegistryError(
                f"{where}: an unlabelled item needs an id '{section}.d<k>' or "
                f"'{section}.s<k>' (its file's section) and a 'quote'"
            )
        if c.method or c.hypothesis_checks:
            raise RegistryError(
                f"{where}: 'method' and 'hypothesis_checks' are for numbered equations"
            )
    for name in ("checks", "literal", "hypothesis_checks"):
        for check in getattr(c, name):
            if check not in known_checks:
                raise RegistryError(
                    f"{where}: field {name!r} names an unknown check {check!r} "
                    f"(oracles/claim_checks)"
                )
    if c.status == "verified" and (not c.checks or (has_label and c.literal)):
        raise RegistryError(f"{where}: a verified claim names its 'checks' (and no 'literal')")
    if c.status in ("erratum", "restriction") and not (c.checks and c.corrected):
        raise RegistryError(f"{where}: an {c.status} names 'checks' and states 'corrected'")
    if c.status == "erratum" and not c.literal:
        raise RegistryError(f"{where}: an erratum names the 'literal' check of the printed form")
    if c.status == "not checkable" and not c.reason:
        raise RegistryError(f"{where}: a claim that is not checkable says why ('reason')")
    if has_label and c.status == "not checkable" and c.checks:
        raise RegistryError(f"{where}: a numbered equation that is not checkable names no 'checks'")
    return c


def load_registry(folder: Path | str | None = None, *, known_checks=None) -> tuple[Claim, ...]:
    """Every entry of the registry's files (:data:`SECTION_FILES` in ``folder``, default
    :data:`REGISTRY_DIR`), in the paper's order, validated (:class:`RegistryError`)."""
    folder = REGISTRY_DIR if folder is None else Path(folder)
    known_checks = CHECKS if known_checks is None else known_checks
    out: list[Claim] = []
    seen: dict[str, str] = {}
    for section in SECTION_FILES:
        path = folder / f"{section}.toml"
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise RegistryError(
                f"{path}: the registry file of section {section!r} is missing"
            ) from None
        except tomllib.TOMLDecodeError as exc:
            raise RegistryError(f"{path.name}: not valid TOML ({exc})") from None
        extra = sorted(set(data) - {"claim"})
        if extra:
            raise RegistryError(
                f"{path.name}: unknown top-level key(s) {extra}; only [[claim]] tables"
            )
        for k, raw in enumerate(data.get("claim", [])):
            c = _entry(path, k, raw, section, known_checks)
            if c.id in seen:
                raise RegistryError(f"{path.name}: claim {c.id!r} is also in {seen[c.id]}")
            seen[c.id] = path.name
            out.append(c)
    return tuple(out)


REGISTRY = load_registry()
CLAIMS = tuple(c for c in REGISTRY if c.label is not None)
"""The numbered equations, in the paper's order."""
UNLABELLED = tuple(c for c in REGISTRY if c.label is None and ".d" in c.id)
SENTENCES = tuple(c for c in REGISTRY if c.label is None and ".s" in c.id)
LABELS = tuple(c.label for c in CLAIMS)
ERRATA = tuple(c for c in CLAIMS if c.status == "erratum")

_VERDICT = {
    "verified": "verified",
    "erratum": "erratum confirmed",
    "restriction": "restriction confirmed",
    "definition": "definition",
    "not checkable": "not checkable",
}


def _outcome(name: str, cache: dict | None) -> Outcome:
    if cache is not None and name in cache:
        return cache[name]
    try:
        o = run_check(name)
    except Exception as exc:  # noqa: BLE001 - a crashing check is a failed check
        o = Outcome(False, None, None, f"{type(exc).__name__}: {exc}")
    if cache is not None:
        cache[name] = o
    return o


def _verdict(c: Claim, res: dict) -> str:
    """All ``checks`` pass and all ``literal`` checks fail -> the status' verdict, else
    ``CONTRADICTED``; ``not checkable`` is never contradicted."""
    good = all(res[n].ok for n in c.checks) and all(not res[n].ok for n in c.literal)
    return _VERDICT[c.status] if good or c.status == "not checkable" else "CONTRADICTED"


@dataclass
class Observation:
    claim: Claim
    verdict: str
    results: dict = field(default_factory=dict)
    seconds: float = 0.0


def evaluate(claims=CLAIMS, *, cache: dict | None = None) -> list[Observation]:
    """Run every check named by the claims (each once) and compare with the recorded status.

    verified: all ``checks`` pass -> ``verified`` else ``CONTRADICTED``; erratum: all ``checks`` pass
    and all ``literal`` checks fail -> ``erratum confirmed`` else ``CONTRADICTED``; not checkable ->
    ``not checkable``.
    """
    cache = {} if cache is None else cache
    out = []
    for c in claims:
        t0 = time.perf_counter()
        res = {name: _outcome(name, cache) for name in c.checks + c.literal}
        out.append(Observation(c, _verdict(c, res), res, time.perf_counter() - t0))
    return out


def _fmt(o) -> str:
    # one significant digit: the report must not change from run to run
    word = "pass" if o.ok else "fail"
    if o.error is None or not o.tolerance:
        return word
    return f"{word} ({o.error:.0e}/{o.tolerance:.0e})"


def render_markdown(obs: list[Observation]) -> str:
    lines = [
        "# The paper's claims",
        "",
        (
            "One row per numbered equation (the paper's `\\label`; the second `drie5` is `drie12`). "
            "Status: `verified`, `erratum` (printed form fails its check, corrected form passes), "
            "`not checkable` (definitions). The registry is `oracles/registry/*.toml` "
            "(`oracles/claims.py`), the checks are in `oracles/claim_checks/` "
            "(run by `tstarg claims`); error/tolerance shown where numeric, to one digit. "
            "Every displayed formula (labelled or not) and every mathematical sentence follows "
            "below the errata."
        ),
        "",
        "| label | section | claim | method | status | observed | checks | tests |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for o in obs:
        c = o.claim
        checks = "; ".join(f"`{n}` {_fmt(o.results[n])}" for n in c.checks)
        if c.literal:
            checks += "; printed: " + "; ".join(f"`{n}` {_fmt(o.results[n])}" for n in c.literal)
        tests = "<br>".join(f"`{t}`" for t in c.tests)
        extra = c.reason or c.remark
        lines.append(
            f"| {c.label} | {c.section} | {c.claim.replace('|', '∣')}{(' — ' + extra.replace('|', '∣')) if extra else ''} "
            f"| {c.method} | {c.status} | {o.verdict} | {checks or '-'} | {tests or '-'} |"
        )
    lines += ["", "## Errata", ""]
    for c in ERRATA:
        lines.append(
            f"* **{c.label}**: {c.corrected} (printed check: {', '.join(c.literal)}; corrected: {', '.join(c.checks)})"
        )
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ the paper's displays and sentences
def labelled_display_entry(display_id: str, labels: tuple, latex: str, claims=CLAIMS) -> Claim:
    """The entry of a labelled display, from its numbered equations (second ``drie5`` = ``drie12``):
    erratum if one of its labels is, else verified if one is, else definition / not checkable; the
    checks are the equations' ``checks`` and ``hypothesis_checks``."""
    by = {c.label: c for c in claims}
    cs: list[Claim] = [by[lab] for lab in labels]
    statuses = {c.status for c in cs}
    if "erratum" in statuses:
        status = "erratum"
    elif "verified" in statuses:
        status = "verified"
    else:
        status = (
            "definition"
            if all(c.reason.startswith("a definition") for c in cs)
            else "not checkable"
        )
    checks = tuple(dict.fromkeys([n for c in cs for n in c.checks + c.hypothesis_checks]))
    literal = tuple(dict.fromkeys(n for c in cs for n in c.literal))
    return Claim(
        display_id,
        section=cs[0].section,
        quote=f"\\label{{{labels[0]}}}",
        claim="; ".join(c.claim for c in cs),
        status=status,
        checks=checks,
        literal=literal,
        corrected=" / ".join(c.corrected for c in cs if c.corrected),
        reason=" / ".join(c.reason for c in cs if c.reason),
        evidence=" / ".join(c.remark for c in cs if c.remark),
        attained=" / ".join(dict.fromkeys(c.attained for c in cs if c.attained)),
        needed=" / ".join(dict.fromkeys(c.needed for c in cs if c.needed)),
        labels=tuple(labels),
    )


def _renamed(labels_in_order):
    seen, out = set(), []
    for lab in labels_in_order:
        out.append("drie12" if lab == "drie5" and lab in seen else lab)
        seen.add(lab)
    return out


def entries_for(index: PaperIndex) -> list[tuple[object, Claim | None]]:
    """Pair every display and sentence of ``index`` with its entry (``None`` when the registry has
    none), in the paper's order."""
    all_labels = _renamed([lab for d in index.displays for lab in d.labels])
    it = iter(all_labels)
    unl = {e.id: e for e in UNLABELLED}
    sen = {e.id: e for e in SENTENCES}
    known = set(LABELS)
    out: list[tuple[object, Claim | None]] = []
    for d in index.displays:
        if d.labels:
            labs = tuple(next(it) for _ in d.labels)
            e = labelled_display_entry(d.id, labs, d.latex) if set(labs) <= known else None
            if e is not None:  # anchor on the label as printed (drie12 is printed drie5)
                e = replace(e, quote=f"\\label{{{d.labels[0]}}}")
            out.append((d, e))
        else:
            out.append((d, unl.get(d.id)))
    for s in index.sentences:
        out.append((s, sen.get(s.id)))
    return out


def coverage(index: PaperIndex) -> dict:
    """Counts and the mismatches between the paper's items and the registry:
    ``missing`` (items without an entry), ``misanchored`` (entry whose ``quote`` is not in the item's
    text), ``extra`` (entries naming no item of the paper)."""
    pairs = entries_for(index)
    missing = [item.id for item, e in pairs if e is None]
    mis = []
    for item, e in pairs:
        if e is None:
            continue
        text = normalise(item.latex if hasattr(item, "latex") else item.text)
        if normalise(e.quote) not in text:
            mis.append(item.id)
    ids = {item.id for item, _ in pairs}
    extra = [e.id for e in UNLABELLED + SENTENCES if e.id not in ids]
    nd, ns = len(index.displays), len(index.sentences)
    with_entry = sum(1 for _, e in pairs if e is not None)
    return {
        "displays": nd,
        "labelled_displays": sum(1 for d in index.displays if d.labels),
        "sentences": ns,
        "items": nd + ns,
        "entries": with_entry,
        "missing": missing,
        "misanchored": mis,
        "extra": extra,
    }


# ------------------------------------------------------------------ evaluation and report
@dataclass
class EntryObservation:
    item: object
    entry: Claim
    verdict: str
    results: dict


def evaluate_entries(index: PaperIndex) -> list[EntryObservation]:
    """Run each entry's checks (cached; each once) and compare with its status.

    verified -> all ``checks`` pass; erratum / restriction -> all ``checks`` pass and all ``literal``
    checks fail; definition -> its ``checks`` (if any) pass; otherwise ``CONTRADICTED``.
    Raises ``ValueError`` if an item of the paper has no entry (see :func:`coverage`)."""
    out = []
    for item, e in entries_for(index):
        if e is None:
            raise ValueError(f"paper item {item.id} has no registry entry")
        res = {name: _outcome(name, None) for name in e.checks + e.literal}
        out.append(EntryObservation(item, e, _verdict(e, res), res))
    return out


def fmt_outcome(o: Outcome) -> str:
    """``pass``/``fail`` with the defect and its bound at one significant digit (stable across runs);
    for exact checks (no error) the check's own finding."""
    word = "pass" if o.ok else "fail"
    if o.error is None or not o.tolerance:
        return f"{word} ({_md_escape(o.detail)})" if o.detail and o.error is None else word
    return f"{word} (error {o.error:.0e}, bound {o.tolerance:.0e})"


def _md_escape(s: str) -> str:
    return s.replace("|", "∣")


def render_entries_markdown(index: PaperIndex, obs: list[EntryObservation]) -> str:
    """The coverage summary, one block per display and per sentence, and the errata found there."""
    cov = coverage(index)
    by_status = Counter(o.verdict for o in obs)
    lines = [
        "## Coverage",
        "",
        (
            f"* displayed formulas in the paper: {cov['displays']} ({cov['labelled_displays']} labelled, "
            f"{cov['displays'] - cov['labelled_displays']} unlabelled); mathematical sentences: "
            f"{cov['sentences']} (rule: oracles/paper_index.py)"
        ),
        (
            f"* items: {cov['items']}; with a registry entry: {cov['entries']}; missing: "
            f"{len(cov['missing'])}; misanchored: {len(cov['misanchored'])}; extra: {len(cov['extra'])}"
        ),
        "* observed: " + ", ".join(f"{k} {v}" for k, v in sorted(by_status.items())),
        "",
    ]

    def block(o: EntryObservation, head: str, body: list[str]) -> list[str]:
        e = o.entry
        out = [head, ""] + body
        out.append(f"* status: **{e.status}**; observed: {o.verdict}")
        out.append(f"* claim: {_md_escape(e.claim)}")
        if e.labels:
            out.append("* labels: " + ", ".join(e.labels))
        if e.corrected:
            out.append(f"* corrected: {_md_escape(e.corrected)}")
        if e.reason:
            out.append(f"* why: {_md_escape(e.reason)}")
        if e.checks or e.literal:
            chk = "; ".join(f"`{n}` {fmt_outcome(o.results[n])}" for n in e.checks)
            if e.literal:
                chk += "; printed form: " + "; ".join(
                    f"`{n}` {fmt_outcome(o.results[n])}" for n in e.literal
                )
            out.append(f"* checks: {chk}")
        if e.evidence:
            out.append(f"* evidence: {_md_escape(e.evidence)}")
        if e.attained:
            out.append(f"* bound attained: {_md_escape(e.attained)}")
        if e.needed:
            out.append(f"* hypothesis: {_md_escape(e.needed)}")
        return out + [""]

    lines += ["## Displayed formulas", ""]
    for o in obs:
        if hasattr(o.item, "latex"):
            d = o.item
            kind = ("labelled " + ", ".join(o.entry.labels)) if d.labels else "unlabelled"
            lines += block(o, f"### {d.id} ({kind}, {d.env})", ["```latex", d.latex, "```", ""])
    lines += ["## Mathematical sentences", ""]
    for o in obs:
        if not hasattr(o.item, "latex"):
            lines += block(o, f"### {o.item.id}", [f"> {o.item.text}", ""])
    lines += ["## Errata among the unlabelled formulas and the sentences", ""]
    for o in obs:
        e = o.entry
        if e.status == "erratum" and not (hasattr(o.item, "latex") and o.item.labels):
            lines.append(
                f"* **{o.item.id}** ({o.verdict}): {_md_escape(e.corrected)} (printed check: "
                f"{', '.join(e.literal)}; corrected: {', '.join(e.checks)})"
            )
    return "\n".join(lines) + "\n"
