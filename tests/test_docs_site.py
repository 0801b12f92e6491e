"""The documentation site builds with ``mkdocs build --strict`` (no warning) and holds no
broken internal link: headless Chromium (Debian's ``chromium`` through Selenium and
``chromium-driver``) opens every page from file://, every link and image inside the site
resolves to a file (and every ``#anchor`` to an element of its page), and a screenshot of
the home page is saved to ``$NSRMP_BENCH_ARTIFACTS`` (default ``test-artifacts/``).
Skips when MkDocs (the docs extra) or Chromium is missing."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlparse

import pytest

REPO = Path(__file__).resolve().parents[1]
pytest.importorskip("mkdocs", reason="MkDocs is not installed (pip install -e '.[docs]')")
pytest.importorskip("material", reason="MkDocs Material is not installed (the docs extra)")
pytest.importorskip("mkdocstrings", reason="mkdocstrings is not installed (the docs extra)")


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("docs-site")
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(out), "--config-file", str(REPO / "mkdocs.yml")],
                          cwd=REPO, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert done.returncode == 0, done.stderr[-4000:]
    warnings = [line for line in done.stderr.splitlines() if "WARNING" in line]
    assert not warnings, "\n".join(warnings)
    return out


def test_every_page_of_the_nav_is_built(site: Path) -> None:
    for page in ("index.html", "getting-started/index.html", "cli/index.html",
                 "api/index.html", "architecture/index.html", "performance/index.html",
                 "models/nsrm-v2/index.html", "robustness/index.html"):
        assert (site / page).is_file(), page
    cli = (site / "cli" / "index.html").read_text("utf-8")
    assert "nsrmp-bench score" in cli and "--breakdown" in cli  # rendered from argparse
    card = (site / "models" / "nsrm-v2" / "index.html").read_text("utf-8")
    assert "Model card" in card  # the card, included at build time


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    webdriver = pytest.importorskip("selenium.webdriver")
    if CHROMIUM is None or DRIVER is None:
        pytest.skip("headless Chromium is not installed (apt-get install chromium "
                    "chromium-driver)")
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = str(CHROMIUM)
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1280,900", "--allow-file-access-from-files"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(executable_path=str(DRIVER)), options=options)
    try:
        yield driver
    finally:
        driver.quit()


def _links(browser: Any) -> list[str]:
    """Every link and image of the open page, as the browser resolved them."""
    found: list[str] = browser.execute_script(
        "return Array.from(document.querySelectorAll('a[href]')).map(a => a.href)"
        ".concat(Array.from(document.images).map(i => i.src));")
    return found


def _open(browser: Any, page: Path) -> None:
    """Load ``page`` and wait until its document is complete: loading the page the browser
    is on already can return before the reloaded document is there."""
    browser.get("about:blank")
    browser.get(page.as_uri())
    deadline = time.monotonic() + 10.0
    while (browser.execute_script("return document.readyState") != "complete"
           and time.monotonic() < deadline):
        time.sleep(0.05)


def _ids(browser: Any) -> set[str]:
    return set(browser.execute_script(
        "return Array.from(document.querySelectorAll('[id]')).map(e => e.id);"))


def test_every_internal_link_resolves_in_chromium(site: Path, browser: Any) -> None:
    start = site / "index.html"
    to_visit, seen, broken = [start.resolve()], set(), []
    anchors: list[tuple[Path, str, Path]] = []
    while to_visit:
        page = to_visit.pop()
        if page in seen:
            continue
        seen.add(page)
        _open(browser, page)
        for href in _links(browser):
            url = urlparse(href)
            if url.scheme != "file":
                continue  # the repository link, fonts: not the site's
            target = Path(unquote(url.path))
            if target.is_dir():
                target = target / "index.html"
            if not target.resolve().is_relative_to(site.resolve()) or not target.exists():
                broken.append(f"{page.relative_to(site)} -> {href}")
                continue
            if url.fragment:
                anchors.append((page, url.fragment, target.resolve()))
            if target.suffix == ".html":
                to_visit.append(target.resolve())
    ids: dict[Path, set[str]] = {}
    for page, fragment, target in anchors:
        if target not in ids:
            _open(browser, target)
            ids[target] = _ids(browser)
        if unquote(fragment) not in ids[target]:
            broken.append(f"{page.relative_to(site)} -> {target.relative_to(site)}#{fragment}")
    assert len(seen) >= 20, sorted(str(p.relative_to(site)) for p in seen)
    assert not broken, "broken internal links:\n" + "\n".join(sorted(set(broken)))

    _open(browser, start)
    loaded = browser.execute_script(
        "return Array.from(document.images).every(i => i.complete && i.naturalWidth > 0);")
    assert loaded, "an image of the home page did not load"
    artifacts = Path(os.environ.get("NSRMP_BENCH_ARTIFACTS", REPO / "test-artifacts"))
    artifacts.mkdir(parents=True, exist_ok=True)
    assert browser.save_screenshot(str(artifacts / "docs-home.png"))
