"""The static leaderboard opened from file:// in headless Chromium (Debian's ``chromium``,
driven by Selenium through ``chromium-driver``) at 1280 px: rows equal the JSON boards,
no element of any page reaches past the window's right edge, sorting reorders the rows,
the protocol filter hides rows, every image loads and every link resolves to a file
inside the site folder. A screenshot of the paper-v2 board is saved to
``$NSRMP_BENCH_ARTIFACTS`` (default ``test-artifacts/``); ``scripts/site_screenshots.py``
writes every page at 1280 and 1920 px for review."""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlparse

import pytest
from site_build import BOARDS, REPO, build_site

pytest.importorskip("matplotlib")
webdriver = pytest.importorskip("selenium.webdriver")

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
if CHROMIUM is None or DRIVER is None:
    pytest.skip("headless Chromium is not installed (apt-get install chromium chromium-driver)",
                allow_module_level=True)

METRICS = ("iou_m", "iou", "success", "program_exact", "identification", "placement")


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_site(tmp_path_factory.mktemp("site"))


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
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


def _open(browser: Any, page: Path) -> None:
    browser.get(page.as_uri())
    browser.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "Promise.all(Array.from(document.images).map(i => i.complete ? 0 :"
        " new Promise(r => { i.onload = i.onerror = r; }))).then(() => done(0));")


def _rows(browser: Any) -> list[dict[str, Any]]:
    return browser.execute_script(
        "const heads = Array.from(document.querySelectorAll('#board thead th'))"
        "  .map(h => h.getAttribute('data-metric'));"
        "return Array.from(document.querySelectorAll('#board tbody tr')).map(tr => {"
        "  const out = {entry: tr.getAttribute('data-entry'), values: {}};"
        "  Array.from(tr.cells).forEach((td, i) => {"
        "    if (heads[i]) { out.values[heads[i]] = td.getAttribute('data-value'); } });"
        "  out.model = tr.cells[1].textContent; return out; });")


def _board(split_stem: str) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = json.loads((BOARDS / f"{split_stem}.json").read_text())["rows"]
    return rows


def _value(triple: Any) -> float | None:
    return None if triple is None or triple[0] is None else float(triple[0])


def test_every_board_page_shows_the_json_board_rows(site: Path, browser: Any) -> None:
    stems = sorted(p.stem for p in BOARDS.glob("*.json"))
    assert stems, "no committed boards"
    for stem in stems:
        _open(browser, site / f"{stem}.html")
        shown = _rows(browser)
        board = _board(stem)
        assert [r["entry"] for r in shown] == [r["entry"] for r in board], stem
        assert [r["model"] for r in shown] == [r["model"] for r in board], stem
        for got, want in zip(shown, board, strict=True):
            for m in METRICS:
                text = got["values"][m]
                assert (None if text == "" else float(text)) == _value(want["metrics"].get(m)), \
                    (stem, want["entry"], m)


def _click(browser: Any, metric: str) -> None:
    browser.find_element("css selector", f'#board th[data-metric="{metric}"] button').click()


def test_sorting_by_a_column_reorders_the_rows(site: Path, browser: Any) -> None:
    board = _board("paper-v2-test")
    _open(browser, site / "paper-v2-test.html")
    by_iou = sorted(board, key=lambda r: -r["metrics"]["iou"][0])
    assert [r["entry"] for r in by_iou] != [r["entry"] for r in board], \
        "the test needs a board whose IoU order differs from its IoU-M order"
    iou = {r["entry"]: r["metrics"]["iou"][0] for r in board}  # ties may come either way
    _click(browser, "iou")
    shown = [r["entry"] for r in _rows(browser)]
    assert sorted(shown) == sorted(iou)
    assert [iou[e] for e in shown] == [iou[r["entry"]] for r in by_iou]
    header = browser.find_element("css selector", '#board th[data-metric="iou"]')
    assert header.get_attribute("aria-sort") == "descending"
    _click(browser, "iou")
    shown = [r["entry"] for r in _rows(browser)]
    assert [iou[e] for e in shown] == [iou[r["entry"]] for r in reversed(by_iou)]
    assert header.get_attribute("aria-sort") == "ascending"
    browser.find_element("css selector", "#board th:nth-child(2) button").click()
    assert [r["model"] for r in _rows(browser)] == sorted(r["model"] for r in board)


def _pages(site: Path) -> list[Path]:
    return sorted([*site.glob("*.html"), *site.glob("cards/*.html")])


def test_no_element_overflows_at_1280_px(site: Path, browser: Any) -> None:
    assert browser.execute_script("return window.innerWidth;") <= 1280
    for page in _pages(site):
        _open(browser, page)
        wide = browser.execute_script(
            "const w = document.documentElement.clientWidth;"
            "return [document.documentElement.scrollWidth, w,"
            " Array.from(document.querySelectorAll('body *'))"
            "  .filter(e => e.getBoundingClientRect().right > w + 0.5)"
            "  .map(e => e.tagName + '.' + e.className + ' ' + e.textContent.slice(0, 30))];")
        scroll, width, over = wide
        assert scroll <= width and not over, (page.name, scroll, width, over[:5])


def test_the_protocol_filter_hides_rows(site: Path, browser: Any) -> None:
    _open(browser, site / "paper-v2-test.html")
    visible = ("return Array.from(document.querySelectorAll('#board tbody tr'))"
               ".filter(r => !r.hidden).map(r => r.getAttribute('data-entry'));")
    every = browser.execute_script(visible)
    browser.find_element("css selector", 'input[data-filter="protocol"][value="detected boxes"]'
                         ).click()
    shown = browser.execute_script(visible)
    assert shown and len(shown) < len(every)
    assert not any("+" in entry for entry in shown)
    browser.find_element("css selector", 'input[data-filter="reference"]').click()
    assert not any(e.endswith(("oracle-v1", "noop-v1", "random-v1"))
                   for e in browser.execute_script(visible))


def test_every_image_loads_and_every_link_is_a_file_inside_the_site(site: Path,
                                                                    browser: Any) -> None:
    """Inside the site, or a committed predictions file beside it (not copied)."""
    images = 0
    for page in _pages(site):
        _open(browser, page)
        sizes = browser.execute_script(
            "return Array.from(document.images).map(i => [i.src, i.naturalWidth]);")
        assert all(width > 0 for _, width in sizes), (page.name, sizes)
        images += len(sizes)
        urls = browser.execute_script(
            "return Array.from(document.querySelectorAll('a[href], link[href], script[src], "
            "img[src]')).map(e => e.href || e.src);")
        for url in urls:
            parsed = urlparse(url)
            assert parsed.scheme == "file", f"{page.name} fetches {url}"
            target = Path(unquote(parsed.path))
            assert target.is_file(), f"{page.name}: broken link {url}"
            assert not target.is_symlink(), f"{page.name}: {url} is a link, not a copy"
            assert Path(os.path.normpath(target)).is_relative_to(site) or \
                Path(os.path.normpath(target)).is_relative_to(site.parent / "predictions"), \
                f"{page.name} links {url}, outside the site and leaderboards/predictions/"
    assert images >= 3 + 3, "the index and the paper-v2 page show the three figures"


def test_every_entry_links_its_predictions_and_a_model_card(site: Path, browser: Any) -> None:
    _open(browser, site / "paper-v2-test.html")
    links = browser.execute_script(
        "return Array.from(document.querySelectorAll('#board tbody tr')).map(tr =>"
        " Array.from(tr.querySelectorAll('a')).map(a => a.href));")
    assert links and all(len(row) == 2 for row in links)
    for predictions, card in links:
        assert predictions.endswith(".jsonl.gz")
        _open(browser, Path(unquote(urlparse(card).path)))
        facts = browser.execute_script(
            "return Array.from(document.querySelectorAll('dl.card:not(.protocol) dt'))"
            ".map(d => d.textContent);")
        assert facts == ["training data", "training time", "parameters", "supervision",
                         "inputs it reads"]
        protocol = browser.execute_script(
            "return Array.from(document.querySelectorAll('dl.protocol dt'))"
            ".map(d => d.textContent);")
        assert protocol == ["supervision", "boxes", "training parts", "seeds", "scorer",
                            "manifest root hash"], protocol  # every committed entry states it
        _open(browser, site / "paper-v2-test.html")


def test_screenshot_of_the_paper_board(site: Path, browser: Any) -> None:
    out = Path(os.environ.get("NSRMP_BENCH_ARTIFACTS", REPO / "test-artifacts"))
    out.mkdir(parents=True, exist_ok=True)
    _open(browser, site / "paper-v2-test.html")
    shot = out / "site-paper-v2-test.png"
    assert browser.save_screenshot(str(shot))
    assert shot.stat().st_size > 10_000
    _open(browser, site / "index.html")
    assert browser.save_screenshot(str(out / "site-index.png"))
