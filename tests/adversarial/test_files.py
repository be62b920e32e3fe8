"""Malformed files for every command that reads one (issue 30, "Scenes and reports"): a FIFO,
devices, empty, truncated, a list, wrong types, NaN digits, deep nesting, binary, an empty folder,
``..toml``, a missing file. Each gets one line on stderr and exit 2, never a traceback, never a
hang, and nothing is written. Run in this process (cheap); ``probe.py`` runs the same cases as
processes with a hard timeout."""

from __future__ import annotations

import pytest

from tests.adversarial import files
from tstarg.reports import cli


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return files.make_inputs(tmp_path_factory.mktemp("inputs"))


CASES = [
    "empty",
    "truncated_json",
    "a_list",
    "wrong_types",
    "nan_digits",
    "deep_json",
    "deep_toml",
    "binary",
    "truncated_toml",
    "toml_list",
    "fifo",
    "dev_zero",
    "dev_urandom",
    "empty_folder",
    "dotdot_toml",
    "missing",
]


@pytest.mark.parametrize(
    "command", ["run", "verify --baseline", "report", "report --compare", "certify --replay"]
)
@pytest.mark.parametrize("case", CASES)
def test_malformed_file_is_one_line_exit_2(inputs, tmp_path, capsys, case, command):
    argv = files.commands(inputs[case], tmp_path)[command]
    rc = cli.main(argv)
    out, err = capsys.readouterr()
    assert rc == 2, (out[-500:], err[-500:])
    assert err.strip() and err.strip().count("\n") == 0 and "Traceback" not in err, err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_case_list_is_the_probe_list(inputs):
    assert set(CASES) == set(inputs)
