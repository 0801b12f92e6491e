"""MkDocs hooks of the documentation site (``mkdocs.yml``: ``hooks``).

- ``<!-- include: PATH -->`` on a line of its own is replaced by the file ``PATH`` (relative
  to the repository root), its headings one level down: the model cards, the formats and
  the contract stay in one place, beside the code, and the site shows them.
- ``<!-- cli-reference -->`` is replaced by every verb's ``--help``
  (:func:`nsrmp_bench.cli.reference.render_markdown`).
- The committed leaderboard figures (``leaderboards/site/figures/*.png``) are served at
  ``figures/`` without being copied into ``docs/``.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "leaderboards" / "site" / "figures"
INCLUDE = re.compile(r"^<!-- include: (?P<path>\S+) -->$", re.M)
HEADING = re.compile(r"^(#{1,5}) ", re.M)
FENCE = re.compile(r"^```.*?^```", re.M | re.S)


def _demote(text: str) -> str:
    """Every Markdown heading one level down, fenced code left alone."""
    out, last = [], 0
    for m in FENCE.finditer(text):
        out.append(HEADING.sub(r"#\1 ", text[last:m.start()]))
        out.append(m.group(0))
        last = m.end()
    out.append(HEADING.sub(r"#\1 ", text[last:]))
    return "".join(out)


def _include(match: re.Match[str]) -> str:
    path = ROOT / match.group("path")
    if not path.is_file():
        msg = f"docs include: {match.group('path')} is not a file of the repository"
        raise FileNotFoundError(msg)
    return _demote(path.read_text("utf-8"))


def on_page_markdown(markdown: str, **_: Any) -> str:
    markdown = INCLUDE.sub(_include, markdown)
    if "<!-- cli-reference -->" in markdown:
        from nsrmp_bench.cli.reference import render_markdown

        markdown = markdown.replace("<!-- cli-reference -->", render_markdown())
    return markdown


def on_files(files: Files, config: Any, **_: Any) -> Files:
    for png in sorted(FIGURES.glob("*.png")):
        files.append(File(f"figures/{png.name}", str(FIGURES.parent), config["site_dir"],
                          config["use_directory_urls"]))
    return files
