"""The documentation site: ``mkdocs build --strict`` passes (warnings are errors), the API reference
renders the docstrings of the four packages, the errata of the claims registry are on the
conventions page, and every code block of the pages runs (a block not meant to run is marked
``<!-- docs-test: skip (reason) -->`` on the line before it)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(
    p
    for p in DOCS.rglob("*.md")
    if not any(part.startswith("_") for part in p.relative_to(DOCS).parts)
)
FENCE = re.compile(
    r"(?P<mark><!-- docs-test: skip \((?P<why>[^)]*)\) -->\n)?```(?P<lang>[\w-]*)\n(?P<body>.*?)```",
    re.DOTALL,
)
SNIPPET = re.compile(r'^--8<-- "(?P<path>[^"]+)"$', re.MULTILINE)
RUN = {"python", "bash"}
# shell blocks run whole command lines (certifications, a scene, builds with gcc): tens of seconds
# per page on a loaded machine, so they carry the slow marker (python -m pytest -m slow tests/test_docs.py)


def _blocks(page: Path):
    """``(lang, body, skip_reason)`` of every fenced block, snippets (``--8<--``) expanded."""
    text = page.read_text()
    out = []
    for m in FENCE.finditer(text):
        body = SNIPPET.sub(lambda s: (ROOT / s["path"]).read_text(), m["body"])
        out.append((m["lang"], body, m["why"] if m["mark"] else None))
    return out


def _rel(page: Path) -> str:
    return page.relative_to(DOCS).as_posix()


@pytest.fixture
def sandbox(tmp_path, monkeypatch):
    """A working folder like a clone's root: the commands' outputs land here, not in the repository."""
    for name in ("examples", "refimpl"):
        (tmp_path / name).symlink_to(ROOT / name)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_every_block_runs_or_says_why_not():
    assert PAGES, "no documentation pages found"
    seen = 0
    for page in PAGES:
        for lang, _, why in _blocks(page):
            seen += 1
            assert lang, f"{_rel(page)}: a code block without a language"
            if why is not None:
                assert len(why.strip()) > 10, (
                    f"{_rel(page)}: a skipped block needs a reason, got {why!r}"
                )
            else:
                assert lang in RUN, (
                    f"{_rel(page)}: a {lang} block is neither run nor marked skip (with a reason)"
                )
    assert seen > 20


@pytest.mark.parametrize(
    "page",
    [p for p in PAGES if any(lg == "python" and w is None for lg, _, w in _blocks(p))],
    ids=_rel,
)
def test_python_blocks_run(page, sandbox):
    namespace = {"__name__": f"docs_{page.stem}"}
    for k, (lang, body, why) in enumerate(_blocks(page)):
        if lang == "python" and why is None:
            exec(compile(body, f"{_rel(page)}[block {k}]", "exec"), namespace)  # noqa: S102 - the docs' own code


def _shell_pages():
    out = []
    for p in PAGES:
        if any(lg == "bash" and w is None for lg, _, w in _blocks(p)):
            out.append(pytest.param(p, marks=[pytest.mark.slow], id=_rel(p)))
    return out


@pytest.mark.parametrize("page", _shell_pages())
def test_shell_blocks_run(page, sandbox):
    bodies = [body for lang, body, why in _blocks(page) if lang == "bash" and why is None]
    for tool in ("gcc", "node"):
        if any(re.search(rf"\b{tool}\b", b) for b in bodies) and shutil.which(tool) is None:
            pytest.skip(f"{tool} not found: {_rel(page)} has commands that need it")
    env = dict(
        os.environ,
        OPENBLAS_NUM_THREADS="1",
        OMP_NUM_THREADS="1",
        PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
    )
    for body in bodies:
        # the `tstarg` script on PATH may belong to another checkout: run this one's CLI
        script = re.sub(
            r"(^|[\s;&|(])tstarg (?=[a-z])",
            r"\1python -m tstarg.reports.cli ",
            body,
            flags=re.MULTILINE,
        )
        script = re.sub(
            r"(^|[\s;&|(])python (?=-m )", rf"\1{sys.executable} ", script, flags=re.MULTILINE
        )
        done = subprocess.run(
            ["bash", "-euo", "pipefail", "-c", script],
            cwd=sandbox,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )
        assert done.returncode == 0, (
            f"{_rel(page)}:\n{body}\nexit {done.returncode}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
        )


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    pytest.importorskip("mkdocs", reason="mkdocs not installed: pip install -e '.[docs]'")
    pytest.importorskip(
        "mkdocstrings", reason="mkdocstrings not installed: pip install -e '.[docs]'"
    )
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-4000:]
    return out


def test_site_builds_strict_with_api_reference(site):
    for package, member in (
        ("refimpl", "tstarg.refimpl.Implementation.poisson_tensor"),
        ("refimpl", "tstarg.refimpl.flows.reference_flow"),
        ("properties", "tstarg.properties.runner.run_property"),
        ("oracles", "tstarg.oracles.closed_forms.rigid_body_solution"),
        ("reports", "tstarg.reports.certification.certify"),
    ):
        html = (site / "reference" / package / "index.html").read_text()
        assert f'id="{member}"' in html, f"API page of tstarg.{package} lacks {member}"
    for page in (
        "tutorials/researcher",
        "tutorials/implementer",
        "tutorials/maintainer",
        "protocol",
        "ci",
        "conventions",
        "figures",
    ):
        assert (site / page / "index.html").exists(), page
    figures = (site / "figures" / "index.html").read_text()
    for png in re.findall(r'src="([^"]+\.png)"', figures):
        assert (site / "figures" / png).resolve().exists(), f"figure {png} missing from the site"


def test_conventions_page_lists_every_erratum(site):
    from tstarg.oracles import ERRATA

    html = (site / "conventions" / "index.html").read_text()
    assert ERRATA and "tstarg:errata" not in html
    for claim in ERRATA:
        assert f"<strong>{claim.label}</strong>" in html, (
            f"erratum {claim.label} missing from the conventions page"
        )
