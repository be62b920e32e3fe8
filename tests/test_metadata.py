"""The package as scientific Python publishes one: the version written once (pyproject.toml) and
read everywhere else, ``tstarg --version`` with the commit, an OSI licence stated the same way in
every file, and a CITATION.cff that cites the paper."""

from __future__ import annotations

import functools
import re
import subprocess
import tomllib
from pathlib import Path

import pytest
import yaml

from tstarg.reports import cli, environment

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def test_the_version_is_written_once():
    """pyproject.toml holds the version; no other file of the packages spells it out."""
    version = PYPROJECT["version"]
    assert re.fullmatch(r"\d+\.\d+\.\d+([abrc.]\w*)?", version), version
    literal = re.compile(rf"""["']{re.escape(version)}["']""")
    hits = [
        str(p.relative_to(ROOT))
        for part in ("refimpl", "properties", "oracles", "reports")
        for p in (ROOT / part).rglob("*.py")
        if literal.search(p.read_text())
    ]
    assert hits == [], hits
    import tstarg.refimpl as refimpl
    from tstarg.refimpl.fast import implementation as fast
    from tstarg.refimpl.reference import implementation as reference

    # the installed metadata is what was installed from this pyproject (editable install)
    assert refimpl.__version__ == version
    assert fast.version == reference.version == version


def test_version_command_prints_version_and_commit(capsys):
    rc = cli.main(["--version"])
    assert rc == 0
    out = capsys.readouterr().out.strip()
    m = re.fullmatch(r"tstarg (\S+) \(commit (\S+)\)", out)
    assert m, out
    assert m.group(1) == PYPROJECT["version"]
    head = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True
    )
    if head.returncode != 0:  # not a git checkout (an sdist unpacked): the commit is unknown
        assert m.group(2) == "unknown"
    else:
        assert head.stdout.strip() == m.group(2).removesuffix("+dirty")


def test_version_is_unknown_outside_a_checkout(tmp_path, monkeypatch):
    """Files that are not the project's git checkout (an installed wheel) give ``unknown``."""
    fake = tmp_path / "site-packages" / "tstarg" / "reports" / "cli.py"
    fake.parent.mkdir(parents=True)
    fake.write_text("")
    monkeypatch.setattr(environment, "__file__", str(fake))
    monkeypatch.setattr(
        environment, "git_commit", functools.cache(environment.git_commit.__wrapped__)
    )
    assert cli.commit() == "unknown" and environment.git_commit() is None


def test_the_licence_is_bsd3_everywhere():
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("BSD 3-Clause License")
    for clause in (
        "Redistributions of source code must retain",
        "Redistributions in binary form must reproduce",
        "Neither the name of the copyright holder",
    ):
        assert clause in text
    assert PYPROJECT["license"] == "BSD-3-Clause"
    assert PYPROJECT["license-files"] == ["LICENSE"]
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["license"] == "BSD-3-Clause"
    # PEP 639: no licence classifier beside the SPDX expression
    assert not any(c.startswith("License ::") for c in PYPROJECT["classifiers"])


def test_citation_cites_the_software_and_the_paper():
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert "version" not in cff  # the version lives in pyproject.toml only
    paper = cff["preferred-citation"]
    assert paper["type"] == "article"
    assert paper["title"] == "Modified Symplectic Structures in Cotangent Bundles of Lie Groups"
    assert [a["family-names"] for a in paper["authors"]] == ["Vanhecke", "Sigaud", "da Silva"]
    # the paper's own title page says the same (the shipped index keeps it, paper.tex or not)
    from tstarg.oracles.paper_index import shipped_index

    idx = shipped_index()
    assert idx.title.rstrip(".") == paper["title"]
    for name in ("Vanhecke", "Sigaud", "da Silva"):
        assert name in idx.authors


def test_changelog_and_contributing_exist_and_name_the_version_source():
    log = (ROOT / "CHANGELOG.md").read_text()
    assert "## [Unreleased]" in log and "pyproject.toml" in log
    contrib = (ROOT / "CONTRIBUTING.md").read_text()
    assert ".ci/run" in contrib and "CHANGELOG.md" in contrib


@pytest.mark.parametrize(
    "field", ["description", "readme", "requires-python", "authors", "keywords"]
)
def test_project_metadata_is_complete(field):
    assert PYPROJECT.get(field), field


def test_classifiers_are_known_to_pypi():
    """Each classifier is one of PyPI's (the trove-classifiers list, when installed)."""
    tc = pytest.importorskip("trove_classifiers")
    unknown = [c for c in PYPROJECT["classifiers"] if c not in tc.classifiers]
    assert unknown == [], unknown
