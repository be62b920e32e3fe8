"""The claims registry's data files (oracles/registry/*.toml): one entry type, loaded and validated;
a broken file gets an error naming the file, the entry and the field."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tstarg.oracles import claim_checks as cc
from tstarg.oracles.claims import (
    CLAIMS,
    LABELS,
    REGISTRY,
    REGISTRY_DIR,
    SECTION_FILES,
    SENTENCES,
    UNLABELLED,
    Claim,
    RegistryError,
    load_registry,
)


def test_one_registry_of_one_type():
    """66 numbered equations (in the paper's order), 9 unlabelled displays and 71 sentences, all
    of the one type, each section in its own file, every named check known."""
    assert all(type(c) is Claim for c in REGISTRY)
    assert len(CLAIMS) == 66 and len(UNLABELLED) == 9 and len(SENTENCES) == 71
    assert len(REGISTRY) == len({c.id for c in REGISTRY}) == 146
    assert all(c.id == c.label for c in CLAIMS) and LABELS[0] == "een1" and LABELS[-1] == "zeven3"
    assert all(c.label is None for c in UNLABELLED + SENTENCES)
    assert all(c.id.split(".")[0] == c.section for c in UNLABELLED + SENTENCES)
    assert sorted(p.stem for p in REGISTRY_DIR.glob("*.toml")) == sorted(SECTION_FILES)
    named = {n for c in REGISTRY for n in c.checks + c.literal + c.hypothesis_checks}
    assert named <= set(cc.CHECKS)
    # every check is used by some claim, and each section's checks live in that section's module
    assert set(cc.CHECKS) <= named
    assert set(cc.SECTIONS) <= set(SECTION_FILES)


@pytest.fixture
def registry_copy(tmp_path) -> Path:
    folder = tmp_path / "registry"
    shutil.copytree(REGISTRY_DIR, folder)
    assert load_registry(folder) == REGISTRY  # the copy loads as the original
    return folder


def _edit(folder: Path, name: str, old: str, new: str) -> None:
    p = folder / f"{name}.toml"
    text = p.read_text()
    assert old in text, old
    p.write_text(text.replace(old, new, 1))


@pytest.mark.parametrize(
    ("file", "old", "new", "message"),
    [
        (
            "deux",
            "status = 'erratum'",
            "status = 'wrong'",
            r"deux\.toml: claim 'twee1': field 'status' is 'wrong'",
        ),
        (
            "deux",
            "checks = ['twee1_frame_corrected']",
            "checks = ['no_such_check']",
            r"deux\.toml: claim 'twee1': field 'checks' names an unknown check 'no_such_check'",
        ),
        (
            "deux",
            "method = 'numeric'",
            "method = 'numeric'\ncolour = 'red'",
            r"deux\.toml: claim 'twee1': unknown field\(s\) \['colour'\]",
        ),
        (
            "deux",
            "label = 'twee2'",
            "label = 'twee2'\nid = 'deux.d99'",
            r"deux\.toml: claim #2: exactly one of 'label'",
        ),
        (
            "un",
            "checks = ['een3_transformation']",
            "checks = 'een3_transformation'",
            r"un\.toml: claim 'een3': field 'checks' must be a list of non-empty strings",
        ),
        (
            "un",
            "label = 'een3'",
            "label = 'een2'",
            r"un\.toml: claim 'een2' is also in un\.toml",
        ),
        ("sept", "[[claim]]", "[[claim]\n", r"sept\.toml: not valid TOML"),
        (
            "cinq",
            "id = 'cinq.s01'",
            "id = 'deux.s01'",
            r"cinq\.toml: claim 'deux\.s01': an unlabelled item needs an id 'cinq\.d<k>'",
        ),
    ],
)
def test_a_broken_file_is_named_with_entry_and_field(registry_copy, file, old, new, message):
    _edit(registry_copy, file, old, new)
    with pytest.raises(RegistryError, match=message):
        load_registry(registry_copy)


def test_missing_required_field(registry_copy):
    p = registry_copy / "trois.toml"
    lines = p.read_text().splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith("claim = "))
    p.write_text("\n".join(lines[:k] + lines[k + 1 :]) + "\n")
    with pytest.raises(
        RegistryError, match=r"trois\.toml: claim 'drie1': field 'claim' is required"
    ):
        load_registry(registry_copy)


def test_missing_file(registry_copy):
    (registry_copy / "six.toml").unlink()
    with pytest.raises(
        RegistryError, match=r"six\.toml: the registry file of section 'six' is missing"
    ):
        load_registry(registry_copy)


def test_status_rules_are_enforced(registry_copy):
    """An erratum without its printed-form check, or a verified claim without checks, is refused."""
    _edit(registry_copy, "deux", "literal = ['twee1_frame_printed']\n", "")
    with pytest.raises(RegistryError, match=r"claim 'twee1': an erratum names the 'literal' check"):
        load_registry(registry_copy)
