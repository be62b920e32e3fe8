"""The distribution: one ``tstarg`` namespace in site-packages, package data in the wheel, and a
non-editable install that runs the command line outside the repository."""

from __future__ import annotations

import os
import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(out), str(ROOT)],
        check=True,
        capture_output=True,
        timeout=300,
    )
    (whl,) = out.glob("tstarg-*.whl")
    return whl


def test_wheel_installs_one_namespace_with_its_data(wheel):
    """Every module lives under tstarg/ (nothing generic such as reports/ at the top of site-packages),
    and the scenes and the verify baseline travel with the code."""
    names = zipfile.ZipFile(wheel).namelist()
    top = {n.split("/", 1)[0] for n in names if not n.split("/", 1)[0].endswith(".dist-info")}
    assert top == {"tstarg"}, top
    for part in ("refimpl", "properties", "oracles", "reports"):
        assert f"tstarg/{part}/__init__.py" in names
    assert any(n.startswith("tstarg/refimpl/scenes/") and n.endswith(".toml") for n in names)
    assert "tstarg/reports/baseline/report.json" in names
    assert "tstarg/oracles/registry/deux.toml" in names  # the claims registry (oracles/claims.py)
    entry = next(n for n in names if n.endswith("entry_points.txt"))
    text = zipfile.ZipFile(wheel).read(entry).decode()
    assert "tstarg = tstarg.reports.cli:main" in text


def test_wheel_holds_every_module_of_the_repository(wheel):
    """Every ``.py`` file of the four package folders (subpackages such as refimpl/integrators
    included) is in the wheel under ``tstarg/``: the list comes from the file tree, not from
    pyproject.toml's ``packages``."""
    names = set(zipfile.ZipFile(wheel).namelist())
    want = {
        f"tstarg/{p.relative_to(ROOT).as_posix()}"
        for part in ("refimpl", "properties", "oracles", "reports")
        for p in (ROOT / part).rglob("*.py")
        if "__pycache__" not in p.parts
    }
    assert want - names == set(), sorted(want - names)
    meta = next(n for n in names if n.endswith(".dist-info/METADATA"))
    text = zipfile.ZipFile(wheel).read(meta).decode()
    assert "License-Expression: BSD-3-Clause" in text
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)


@pytest.mark.slow
def test_build_gives_an_sdist_and_a_wheel_that_pass_twine_check(tmp_path):
    """``python -m build`` (the release route of CONTRIBUTING.md) makes both distributions and
    ``twine check`` accepts their metadata (README rendering included)."""
    pytest.importorskip("build", reason='the release tools: pip install -e ".[release]"')
    pytest.importorskip("twine", reason='the release tools: pip install -e ".[release]"')
    subprocess.run(
        [sys.executable, "-m", "build", "-o", str(tmp_path), str(ROOT)],
        check=True,
        capture_output=True,
        timeout=600,
    )
    dists = sorted(p.name for p in tmp_path.iterdir())
    assert any(d.endswith(".tar.gz") for d in dists) and any(d.endswith(".whl") for d in dists)
    r = subprocess.run(
        [sys.executable, "-m", "twine", "check", "--strict", *map(str, tmp_path.iterdir())],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.count("PASSED") == 2, r.stdout


@pytest.mark.slow
def test_non_editable_install_runs_outside_the_repository(wheel, tmp_path):
    """A fresh virtual environment (dependencies from this interpreter's site-packages) with the wheel
    installed runs `tstarg run` on a packaged scene and `tstarg claims` from an unrelated folder."""
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(system_site_packages=True, with_pip=True).create(env_dir)
    py = env_dir / "bin" / "python"
    subprocess.run(
        [str(py), "-m", "pip", "install", "--no-deps", "-q", str(wheel)], check=True, timeout=300
    )
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    code = (
        "import tstarg.refimpl, pathlib; "
        "print(next((pathlib.Path(tstarg.refimpl.__file__).parent / 'scenes').glob('*.toml')))"
    )
    scene = subprocess.run(
        [str(py), "-c", code], cwd=work, env=env, check=True, capture_output=True, text=True
    ).stdout.strip()
    assert "site-packages" in scene
    r = subprocess.run(
        [str(env_dir / "bin" / "tstarg"), "run", scene, "--out", str(work / "run")],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    assert any((work / "run").iterdir())
