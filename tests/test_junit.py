"""JUnit XML of certificates and reports: a standard reader sees one test case per check, a
failure exactly where the certificate failed (with the worst ratio), skips with their reasons."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET

import pytest

from tstarg.reports.certification import certify
from tstarg.reports.junit import main as junit_main
from tstarg.reports.junit import write_junit
from tstarg.reports.mutants import Plain

CHECKS = [
    "poisson_tensor.antisymmetry",
    "poisson_tensor.degenerate",
    "poisson_tensor.reference",
    "hamiltonian_vector_field.reference",
    "poisson_tensor.batch",
]


@pytest.fixture(scope="module")
def certificates():
    """A correct implementation, and a broken one (Upsilon's sign flipped) with one xfail and one skip."""
    good = certify(
        Plain(), max_examples=3, seed=0, checks=CHECKS, target="mutants:Plain()", shrink=False
    ).to_json()
    bad = certify(
        Plain("upsilon_sign"),
        max_examples=4,
        seed=0,
        checks=CHECKS,
        target="mutants:Plain(upsilon_sign)",
        skips={"poisson_tensor.antisymmetry": "skipped on purpose"},
        xfails={"hamiltonian_vector_field.reference": "known wrong"},
        shrink=False,
    ).to_json()
    return good, bad


def _cases(root):
    return {c.get("name"): c for c in root.iter("testcase")}


def test_correct_certificate_is_all_green(certificates, tmp_path):
    good, _ = certificates
    assert good["passed"]
    root = ET.parse(write_junit(good, tmp_path / "good.xml")).getroot()
    suite = root.find("testsuite")
    cases = _cases(root)
    assert set(cases) == {c["name"] for c in good["checks"]} | set(good["skipped"])
    assert suite.get("failures") == "0" and int(suite.get("tests")) == len(cases)
    for c in good["checks"]:
        assert cases[c["name"]].get("classname") == c["name"].split(".")[0]
        assert cases[c["name"]].find("failure") is None
    props = {p.get("name"): p.get("value") for p in suite.iter("property")}
    assert props["target"] == "mutants:Plain()" and props["seed"] == "0"


def test_broken_certificate_fails_with_the_worst_ratio(certificates, tmp_path):
    _, bad = certificates
    assert not bad["passed"]
    root = ET.parse(write_junit(bad, tmp_path / "bad.xml")).getroot()
    cases = _cases(root)
    failed = [
        c
        for c in bad["checks"]
        if not c["passed"] and c["name"].split("[")[0] not in bad["xfailed"]
    ]
    assert failed, "the mutant must fail some check for this test to mean anything"
    assert int(root.get("failures")) == len(failed)
    for c in failed:
        failure = cases[c["name"]].find("failure")
        assert failure is not None
        ratio = float(c["worst_ratio"])
        if ratio > 1:  # failed on accuracy: the message carries the worst ratio
            shown = float(failure.get("message").split("ratio ")[1].split(" ")[0])
            assert math.isclose(shown, ratio, rel_tol=1e-2)
        else:  # failed by an exception (e.g. finite numbers on the degenerate set): its message
            assert failure.get("message") == c["detail"].strip().splitlines()[0][:500]
        assert c["falsifying_example"].strip()[:40] in failure.text
    xfail = [
        c
        for c in bad["checks"]
        if c["name"].startswith("hamiltonian_vector_field") and not c["passed"]
    ]
    for c in xfail:
        sk = cases[c["name"]].find("skipped")
        assert sk is not None and sk.get("message").startswith("xfail: known wrong")
    assert (
        cases["poisson_tensor.antisymmetry"].find("skipped").get("message") == "skipped on purpose"
    )
    # this mutant is not batched: the batch check is a skipped test case carrying the reason
    assert "batched" in cases["poisson_tensor.batch"].find("skipped").get("message")


def test_junitparser_reads_it(certificates, tmp_path):
    junitparser = pytest.importorskip(
        "junitparser", reason="junitparser not installed (pip install -e '.[test]')"
    )
    for doc in certificates:
        path = write_junit(doc, tmp_path / "c.xml")
        xml = junitparser.JUnitXml.fromfile(str(path))
        suites = list(xml) if isinstance(xml, junitparser.JUnitXml) else [xml]
        n_fail = sum(
            1
            for s in suites
            for case in s
            for r in case.result
            if isinstance(r, junitparser.Failure)
        )
        n_cases = sum(len(list(s)) for s in suites)
        assert n_cases == len(doc["checks"]) + len(doc["skipped"])
        assert (n_fail == 0) == doc["passed"]


def test_incidents_fail_the_xml_and_bad_text_is_escaped(tmp_path):
    doc = {
        "implementation": "cmd: prog",
        "version": "external",
        "target": "--cmd prog",
        "seed": 0,
        "max_examples": 3,
        "skipped": {},
        "xfailed": {},
        "passed": False,
        "seconds": 1.0,
        "checks": [
            {
                "name": "poisson_tensor.reference[generic]",
                "passed": False,
                "worst_ratio": "inf",
                "examples": 1,
                "detail": "garbage \x00\x07 <&> from the program",
                "falsifying_example": "x",
                "seconds": 0.5,
            }
        ],
        "incidents": [
            {"id": 5, "method": "poisson_tensor", "kind": "hang", "detail": "no reply within 2 s"}
        ],
    }
    root = ET.parse(write_junit(doc, tmp_path / "x.xml")).getroot()
    cases = _cases(root)
    assert root.get("failures") == "2"
    assert "inf" in cases["poisson_tensor.reference[generic]"].find("failure").get("message")
    assert "<&>" in cases["poisson_tensor.reference[generic]"].find("failure").text
    assert "hang" in cases["program.incidents"].find("failure").text


def test_verify_report_and_cli(tmp_path):
    report = {
        "tool": "tstarg verify",
        "profile": "ci",
        "seed": 0,
        "max_examples": 20,
        "seconds": 3.0,
        "providers": {"a.b:c": "ran 2 checks in 1.0 s", "x.y:z": "skipped: module not found"},
        "passed": False,
        "n_failed": 1,
        "checks": [
            {
                "name": "routes_agree",
                "passed": True,
                "worst_ratio": 1e-20,
                "examples": 20,
                "seconds": 1.0,
                "extra": {"provider": "tstarg.properties.core_checks:core_checks"},
            },
            {
                "name": "regression.speed",
                "passed": False,
                "worst_ratio": 2.5,
                "examples": 1,
                "detail": "speed-up fell",
                "seconds": 0.0,
            },
        ],
    }
    src = tmp_path / "report.json"
    src.write_text(json.dumps(report))
    assert junit_main([str(src)]) == 1
    root = ET.parse(tmp_path / "report.junit.xml").getroot()
    cases = _cases(root)
    assert cases["routes_agree"].get("classname") == "tstarg.properties.core_checks"
    assert cases["regression.speed"].get("classname") == "regression"
    assert cases["provider[x.y:z]"].find("skipped") is not None
    assert root.get("failures") == "1" and root.get("tests") == "3"


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="checks"):
        write_junit({"no": "checks"}, "/nonexistent/never-written.xml")
