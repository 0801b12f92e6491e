"""One version and one licence everywhere: pyproject, the package, CITATION.cff, the
README's BibTeX and the changelog agree; LICENSE is the MIT text pyproject names."""

from __future__ import annotations

import re
from pathlib import Path

import nsrmp_bench

REPO = Path(__file__).resolve().parents[2]


def _field(name: str) -> str:
    """A top-level field of pyproject's [project] table, as written."""
    text = (REPO / "pyproject.toml").read_text("utf-8")
    project = text[text.index("[project]"):text.index("\n[", text.index("[project]"))]
    found = re.search(rf"^{name} = (.+)$", project, re.M)
    assert found, name
    return found.group(1)


def test_one_version_everywhere() -> None:
    version = _field("version").strip('"')
    assert nsrmp_bench.__version__ == version
    cff = (REPO / "CITATION.cff").read_text("utf-8")
    assert re.search(rf"^version: {re.escape(version)}$", cff, re.M), "CITATION.cff version"
    readme = (REPO / "README.md").read_text("utf-8")
    assert f"version = {{{version}}}" in readme, "the README's BibTeX version"
    changelog = (REPO / "CHANGELOG.md").read_text("utf-8")
    assert re.search(rf"^## \[{re.escape(version)}\] - \d{{4}}-\d{{2}}-\d{{2}}$", changelog,
                     re.M), "CHANGELOG.md has no section for this version"


def test_the_citation_and_the_bibtex_agree() -> None:
    cff = (REPO / "CITATION.cff").read_text("utf-8")
    readme = (REPO / "README.md").read_text("utf-8")
    bib = readme[readme.index("@software{nsrmp_bench"):]
    bib = bib[:bib.index("\n}\n")]
    url = re.search(r'^repository-code: "(.+)"$', cff, re.M)
    assert url and f"url     = {{{url.group(1)}}}" in bib
    year = re.search(r'^date-released: "(\d{4})-', cff, re.M)
    assert year and f"year    = {{{year.group(1)}}}" in bib
    assert "The nsrmp-bench authors" in cff and "The nsrmp-bench authors" in bib


def test_the_licence_is_mit() -> None:
    assert _field("license") == '{ text = "MIT" }'
    assert (REPO / "LICENSE").read_text("utf-8").startswith("MIT License")
    assert re.search(r"^license: MIT$", (REPO / "CITATION.cff").read_text("utf-8"), re.M)
