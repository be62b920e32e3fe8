"""MkDocs hooks of the tstarg site (mkdocs.yml: ``hooks``).

* ``on_files``: the committed figures under ``reports/`` (``reports/figures``, ``reports/bench``,
  ``reports/stress``) join the site at the same paths, so pages link them as
  ``reports/bench/heavy_top_wp.png`` without copies that could go stale;
* ``on_pre_page``: one log line per page as it is built (the API pages take seconds each: the
  build says where it is instead of going quiet);
* ``on_page_markdown``: the placeholder ``<!-- tstarg:errata -->`` becomes the list of errata of
  the claims registry (``tstarg.oracles.ERRATA``), so the site shows the registry as it is.
"""

from __future__ import annotations

import html
import logging
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
LOG = logging.getLogger("mkdocs.hooks.tstarg")
FIGURE_DIRS = ("reports/figures", "reports/bench", "reports/stress")


def on_files(files, config):
    for folder in FIGURE_DIRS:
        for png in sorted((ROOT / folder).glob("*.png")):
            files.append(
                File(
                    png.relative_to(ROOT).as_posix(),
                    src_dir=str(ROOT),
                    dest_dir=config["site_dir"],
                    use_directory_urls=config["use_directory_urls"],
                )
            )
    return files


def _errata_markdown() -> str:
    from tstarg.oracles import ERRATA

    lines = []
    for c in ERRATA:
        # the texts are plain ASCII mathematics: <dV|e_m> must be shown, not taken for an HTML tag
        claim, erratum = html.escape(c.claim, quote=False), html.escape(c.corrected, quote=False)
        lines.append(
            f"- **{c.label}** ({c.section}): {claim}. *Erratum:* {erratum} "
            f"(checks: printed form `{', '.join(c.literal) or '-'}` must fail, "
            f"corrected `{', '.join(c.checks) or '-'}` must pass)"
        )
    return "\n".join(lines)


def on_pre_page(page, config, files):
    LOG.info("building %s", page.file.src_uri)
    return page


def on_page_markdown(markdown, page, config, files):
    if "<!-- tstarg:errata -->" in markdown:
        markdown = markdown.replace("<!-- tstarg:errata -->", _errata_markdown())
    return markdown
