"""The documentation site: ``mkdocs build --strict`` passes (warnings are errors), the API reference
renders the docstrings of the four packages, the errata of the claims registry are on the
conventions page, and every code block of the pages runs (a block not meant to run is marked
``<!-- docs-test: skip (reason) -->`` on the line before it)."""

from __future__ import annotations

import contextlib
import io
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
    r"(?P<mark><!-- docs-test: (?:skip \((?P<why>[^)]*)\)|(?P<output>output)) -->\n)?"
    r"```(?P<lang>[\w-]*)\n(?P<body>.*?)```",
    re.DOTALL,
)
OUTPUT = "the printed output of the block above (compared by test_printed_output_matches_the_text)"
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
        why = OUTPUT if m["output"] else (m["why"] if m["mark"] else None)
        out.append((m["lang"], body, why))
    return out


def _expected_after(blocks, k: int) -> str | None:
    """The expected output written right after block ``k`` (a ``docs-test: output`` block), if any."""
    if k + 1 < len(blocks) and blocks[k + 1][2] == OUTPUT:
        return blocks[k + 1][1]
    return None


def _output_pattern(expected: str) -> re.Pattern:
    """The expected output as a pattern: each line must appear in order; ``...`` inside a line
    stands for any text, a line that is only ``...`` for any number of lines."""
    parts = []
    for line in expected.rstrip("\n").splitlines():
        if line.strip() == "...":
            parts.append(r"(?:[^\n]*\n)*?")
        else:
            parts.append(".*?".join(map(re.escape, line.rstrip().split("..."))) + r"[ \t]*\n")
    return re.compile("".join(parts))


def assert_output_matches(actual: str, expected: str, where: str) -> None:
    text = "\n".join(line.rstrip() for line in actual.splitlines()) + "\n"
    assert _output_pattern(expected).fullmatch(text), (
        f"{where}: the printed output differs from what the page shows.\n--- page:\n{expected}"
        f"--- printed:\n{actual}"
    )


def test_output_patterns():
    """Negative controls of the comparison: a changed word, a missing line, lines out of order."""
    shown = "method: taylor-rational (...)\n...\ndrift ...\n"
    ok = "method: taylor-rational (adaptive)\nchose: x\nchose: y\ndrift 1e-16\n"
    assert _output_pattern(shown).fullmatch(ok)
    assert not _output_pattern(shown).fullmatch(ok.replace("taylor-rational", "gauss6"))
    assert not _output_pattern(shown).fullmatch("method: taylor-rational (a)\n")
    assert not _output_pattern(shown).fullmatch("drift 1\nmethod: taylor-rational (a)\n")


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
    """Every Python block runs, in order, in one namespace; where the page shows the output
    (a ``docs-test: output`` block right after), the printed output matches it."""
    namespace = {"__name__": f"docs_{page.stem}"}
    blocks = _blocks(page)
    for k, (lang, body, why) in enumerate(blocks):
        if lang == "python" and why is None:
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                exec(compile(body, f"{_rel(page)}[block {k}]", "exec"), namespace)  # noqa: S102 - the docs' own code
            expected = _expected_after(blocks, k)
            if expected is not None:
                assert_output_matches(buf.getvalue(), expected, f"{_rel(page)}[block {k}]")


def test_every_output_block_follows_a_block_that_runs():
    for page in PAGES:
        blocks = _blocks(page)
        for k, (_, _, why) in enumerate(blocks):
            if why == OUTPUT:
                assert k > 0 and blocks[k - 1][2] is None and blocks[k - 1][0] in RUN, (
                    f"{_rel(page)}: an output block must follow a block that runs"
                )


def _shell_pages():
    out = []
    for p in PAGES:
        if any(lg == "bash" and w is None for lg, _, w in _blocks(p)):
            out.append(pytest.param(p, marks=[pytest.mark.slow], id=_rel(p)))
    return out


@pytest.mark.parametrize("page", _shell_pages())
def test_shell_blocks_run(page, sandbox):
    blocks = _blocks(page)
    runs = [
        (k, body) for k, (lang, body, why) in enumerate(blocks) if lang == "bash" and why is None
    ]
    bodies = [body for _, body in runs]
    for tool in ("gcc", "node"):
        if any(re.search(rf"\b{tool}\b", b) for b in bodies) and shutil.which(tool) is None:
            pytest.skip(f"{tool} not found: {_rel(page)} has commands that need it")
    env = dict(
        os.environ,
        OPENBLAS_NUM_THREADS="1",
        OMP_NUM_THREADS="1",
        PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
    )
    for k, body in runs:
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
        expected = _expected_after(blocks, k)
        if expected is not None:
            assert_output_matches(done.stdout, expected, f"{_rel(page)}[block {k}]")


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
        ("refimpl", "tstarg.refimpl.Implementation"),
        ("refimpl", "tstarg.refimpl.flows.reference_flow"),
        ("properties", "tstarg.properties.runner.run_property"),
        ("oracles", "tstarg.oracles.closed_forms.rigid_body_solution"),
        ("reports", "tstarg.reports.certification.certify"),
    ):
        html = (site / "reference" / f"{package}.html").read_text()
        assert f'id="{member}"' in html, f"API page of tstarg.{package} lacks {member}"
    for page in (
        "tutorials/researcher",
        "tutorials/implementer",
        "tutorials/maintainer",
        "protocol",
        "ci",
        "design",
        "conventions",
        "figures",
    ):
        assert (site / f"{page}.html").exists(), page
    figures = (site / "figures.html").read_text()
    for png in re.findall(r'src="([^"]+\.png)"', figures):
        assert (site / png).resolve().exists(), f"figure {png} missing from the site"


def test_site_links_work_from_disk(site):
    """Opened as files (site/index.html in a browser, no server), every relative link and image of
    every page reaches a file: links name pages (``design.html``), never folders (``design/``)."""
    broken = []
    for page in site.rglob("*.html"):
        if "search" in page.relative_to(site).parts or page.name == "404.html":
            continue  # the 404 page is served by a web server for any path: it links from the root
        for ref in re.findall(r'(?:href|src)="([^"#?]+)(?:[#?][^"]*)?"', page.read_text()):
            if re.match(r"^[a-z][a-z0-9+.-]*:", ref) or ref.startswith("//"):
                continue  # an absolute URL (https:, mailto:, data:)
            target = (page.parent / ref).resolve()
            if not target.is_file():
                broken.append(f"{page.relative_to(site)} -> {ref}")
    assert broken == [], broken[:20]


def test_conventions_page_lists_every_erratum(site):
    from tstarg.oracles import ERRATA

    html = (site / "conventions.html").read_text()
    assert ERRATA and "tstarg:errata" not in html
    for claim in ERRATA:
        assert f"<strong>{claim.label}</strong>" in html, (
            f"erratum {claim.label} missing from the conventions page"
        )
    # the mathematics is text, escaped: drie12's <dV|e_m> is shown, not swallowed as a tag
    drie12 = next(c for c in ERRATA if c.label == "drie12")
    assert "<dV|e_m>" in drie12.claim
    assert "&lt;dV|e_m&gt;" in html and "<dV|e_m>" not in html


def test_the_design_page_states_the_enforced_layering():
    """The design page says what tests/test_architecture.py enforces (the rank order there)."""
    from tests.test_architecture import RANK

    chain = " -> ".join(sorted(RANK, key=RANK.get, reverse=True))
    assert chain == "reports -> oracles -> properties -> refimpl"
    text = (DOCS / "design.md").read_text()
    assert chain in text and "`oracles` may use `properties`" in text
    assert "*public face*" in text and "ALLOWED_PRIVATE" in text  # the private-import rule


def test_nothing_refers_to_files_outside_the_repository():
    """README, docs, help texts and docstrings name the docs pages, never the shared notes
    (CONVENTIONS.md, DESIGN.md) or ../shared/paper.tex, which a clone does not have."""
    bad = []
    files = [ROOT / "README.md", ROOT / "CONTRIBUTING.md", *PAGES]
    for part in ("refimpl", "properties", "oracles", "reports", "examples"):
        files += [p for p in (ROOT / part).rglob("*") if p.suffix in (".py", ".md", ".toml")]
    for f in files:
        text = f.read_text(errors="replace")
        for pat in (
            r"(?<![\w/])CONVENTIONS\.md",
            r"(?<![\w/])DESIGN\.md",
            r"\.\./shared/",
            r"STYLE\.md",
        ):
            if re.search(pat, text):
                bad.append(f"{f.relative_to(ROOT)}: {pat}")
    assert bad == [], bad
