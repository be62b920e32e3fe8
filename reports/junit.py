"""JUnit XML from a certificate or a verification report, for CI systems.

CI services (GitHub Actions test reporters, GitLab, Jenkins, Azure) read JUnit XML. This
module turns the JSON written by ``tstarg certify`` (``certificate.json``, i.e.
``Certificate.to_json()``) or by ``tstarg verify`` (``report.json``) into one
``<testsuites>`` document:

1. one ``<testcase>`` per check: ``name`` is the check id (``poisson_tensor.reference[generic]``),
   ``classname`` its prefix before the first dot (``poisson_tensor``), or, for ids without a dot,
   the check's provider (verify) or the suite name; ``time`` is the check's seconds;
2. a failed check carries ``<failure message="worst error/tolerance ratio R > 1: ...">`` with the
   detail, the minimal falsifying example and the seed to reproduce in its text;
3. a check expected to fail (``--xfails-file``) that failed is ``<skipped message="xfail: ...">``
   (as pytest reports xfail); a check that was not run (missing method, ``--skips-file``, outside
   the declared domain, missing provider) is ``<skipped message="REASON">``;
4. program incidents of ``--cmd`` targets (hangs, crashes, garbage) are one more failed test
   case ``program.incidents``, so that the XML fails exactly when the certificate fails;
5. the suite's ``<properties>`` carry the implementation, version, target, seed, examples per
   check, the reproduce command and, when present, the declared domain and the notes.

Every value goes through :func:`_xml_text`, which drops the characters XML 1.0 forbids (a
``--cmd`` program may print anything into an error message).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

__all__ = ["junit_tree", "write_junit"]

_ILLEGAL_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
_MESSAGE_CHARS = 500


def _xml_text(value: Any) -> str:
    return _ILLEGAL_XML.sub("?", str(value))


def _ratio(value: Any) -> float:
    """``worst_ratio`` as stored in JSON: a number, or ``"inf"`` / ``"nan"`` strings."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _fmt_ratio(r: float) -> str:
    return f"{r:.3g}" if math.isfinite(r) else str(r)


def _fmt_digits(value: Any) -> str:
    d = _ratio(value)  # a number, or "inf" (exact agreement) stored as a string
    return "exact" if d == math.inf else f"{d:.1f}"


def _classname(check_id: str, check: dict, default: str) -> str:
    base = check_id.split("[", 1)[0]
    if "." in base:
        return base.split(".", 1)[0]
    provider = (
        (check.get("extra") or {}).get("provider") if isinstance(check.get("extra"), dict) else None
    )
    if provider:
        return str(provider).split(":", 1)[0]
    return default


def _is_certificate(doc: dict) -> bool:
    return "implementation" in doc and "target" in doc


def _kind(doc: dict) -> str:
    if not isinstance(doc, dict):
        raise TypeError(
            f"write_junit: expected a certificate or verify report dict, got {type(doc).__name__}"
        )
    if not isinstance(doc.get("checks"), list):
        raise ValueError(  # noqa: TRY004 - a dict without the key, not a wrong type
            "write_junit: expected a certificate dict (Certificate.to_json()) or a verify report dict "
            f"(report.json), with a list under 'checks'; got keys {sorted(doc)[:12]}"
        )
    return "certificate" if _is_certificate(doc) else "verify"


def _xfailed(doc: dict, check_id: str) -> str | None:
    xf = doc.get("xfailed") or {}
    return xf.get(check_id.split("[", 1)[0])


def _add_property(props: ET.Element, name: str, value: Any) -> None:
    if value is None or value == "" or value == {}:
        return
    if not isinstance(value, str):
        value = json.dumps(value, default=str, sort_keys=True)
    ET.SubElement(props, "property", name=name, value=_xml_text(value))


def _failure_text(check: dict, doc: dict) -> str:
    parts = [
        str(check.get("detail") or "").strip(),
        str(check.get("falsifying_example") or "").strip(),
    ]
    seed = doc.get("seed")
    cmd = doc.get("command")
    if seed is not None or cmd:
        parts.append(f"reproduce: {cmd or ''} (seed {seed})".strip())
    return _xml_text("\n\n".join(p for p in parts if p))


def junit_tree(doc: dict) -> ET.ElementTree:
    """The JUnit XML tree of a certificate or verify report dict (see the module docstring)."""
    kind = _kind(doc)
    if kind == "certificate":
        suite_name = f"tstarg.certify {doc.get('implementation', '?')}"
        default_class = "certify"
    else:
        suite_name = f"tstarg.verify {doc.get('profile', '')}".strip()
        default_class = "verify"
    root = ET.Element("testsuites", name="tstarg")
    suite = ET.SubElement(root, "testsuite", name=_xml_text(suite_name))
    props = ET.SubElement(suite, "properties")
    for key in (
        "implementation",
        "version",
        "target",
        "tool",
        "profile",
        "seed",
        "max_examples",
        "command",
        "domain",
        "notes",
    ):
        _add_property(props, key, doc.get(key))
    if not len(props):
        suite.remove(props)

    tests = failures = skipped = 0
    total_time = 0.0
    for check in doc["checks"]:
        cid = str(check.get("name", "?"))
        seconds = float(check.get("seconds") or 0.0)
        total_time += seconds
        case = ET.SubElement(
            suite,
            "testcase",
            classname=_xml_text(_classname(cid, check, default_class)),
            name=_xml_text(cid),
            time=f"{seconds:.3f}",
        )
        tests += 1
        ratio = _ratio(check.get("worst_ratio"))
        if check.get("passed", False):
            out = f"examples {check.get('examples', 0)}, worst error/tolerance {_fmt_ratio(ratio)}"
            if check.get("min_digits") is not None:
                out += f", min digits {_fmt_digits(check['min_digits'])}"
            ET.SubElement(case, "system-out").text = _xml_text(out)
            continue
        first_line = (str(check.get("detail") or "").strip().splitlines() or ["check failed"])[0]
        # a check that failed by an exception (a ValueError where none belongs, finite numbers on the
        # degenerate set) has no ratio above 1: its message is the exception's
        message = (
            f"worst error/tolerance ratio {_fmt_ratio(ratio)} > 1: {first_line}"
            if not ratio <= 1
            else first_line
        )
        message = message[:_MESSAGE_CHARS]
        reason = _xfailed(doc, cid)
        if reason is not None:
            ET.SubElement(case, "skipped", message=_xml_text(f"xfail: {reason}; {message}"))
            skipped += 1
            continue
        failure = ET.SubElement(case, "failure", message=_xml_text(message), type="CheckFailed")
        failure.text = _failure_text(check, doc)
        failures += 1

    not_run = dict(doc.get("skipped") or {}) if kind == "certificate" else {}
    if kind == "verify":
        not_run.update(
            {
                f"provider[{k}]": v
                for k, v in (doc.get("providers") or {}).items()
                if str(v).startswith("skipped")
            }
        )
    for cid, why in not_run.items():
        case = ET.SubElement(
            suite,
            "testcase",
            classname=_xml_text(_classname(cid, {}, default_class)),
            name=_xml_text(cid),
            time="0.000",
        )
        ET.SubElement(case, "skipped", message=_xml_text(why))
        tests += 1
        skipped += 1

    incidents = doc.get("incidents") or []
    if incidents:
        case = ET.SubElement(
            suite, "testcase", classname="program", name="program.incidents", time="0.000"
        )
        lines = [
            f"request {i.get('id')} ({i.get('method')}): {i.get('kind')} ({i.get('detail')})"
            for i in incidents
        ]
        failure = ET.SubElement(
            case,
            "failure",
            type="ProgramIncident",
            message=_xml_text(f"{len(incidents)} program incident(s): {lines[0]}"[:_MESSAGE_CHARS]),
        )
        failure.text = _xml_text("\n".join(lines))
        tests += 1
        failures += 1

    seconds = float(doc.get("seconds") or total_time)
    for el in (root, suite):
        el.set("tests", str(tests))
        el.set("failures", str(failures))
        el.set("errors", "0")
        el.set("skipped", str(skipped))
        el.set("time", f"{seconds:.3f}")
    ET.indent(root)
    return ET.ElementTree(root)


def write_junit(certificate_or_report: dict, path: str | Path) -> Path:
    """Write the JUnit XML of a certificate dict (``Certificate.to_json()``) or a ``tstarg verify``
    report dict to ``path`` (parent folders are created); returns the path.

    The document has a failure exactly when the certificate / report did not pass: each failed
    check is a ``<failure>`` (expected failures are ``<skipped>``), and ``--cmd`` program incidents
    are one more failed test case.
    """
    path = Path(path)
    tree = junit_tree(certificate_or_report)
    path.parent.mkdir(parents=True, exist_ok=True)
    tree.write(path, encoding="utf-8", xml_declaration=True)
    return path


def main(argv: list[str] | None = None) -> int:
    """``python -m tstarg.reports.junit certificate.json [out.xml]``: convert a written certificate
    or report; the exit status is 0 when it passed, 1 otherwise."""

    ap = argparse.ArgumentParser(prog="python -m tstarg.reports.junit", description=main.__doc__)
    ap.add_argument("json", help="certificate.json or report.json")
    ap.add_argument("out", nargs="?", help="output XML (default: beside the input, .junit.xml)")
    a = ap.parse_args(argv)
    src = Path(a.json)
    doc = json.loads(src.read_text())
    out = write_junit(doc, a.out or src.with_suffix(".junit.xml"))
    print(f"JUnit XML: {out}")
    return 0 if doc.get("passed", False) else 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
