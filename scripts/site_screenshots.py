"""Full-page screenshots of the static leaderboard at 1280 and 1920 px, for review.

    .venv/bin/python scripts/site_screenshots.py [--site leaderboards/site] [--out DIR]

Opens every page of the site (``index.html``, each board, one model card, and a card
whose entry states no facts if there is one) from ``file://`` in headless Chromium
(Debian's ``chromium`` and ``chromium-driver``, driven by Selenium: the ``dev`` extra) and
writes ``<page>-<width>.png`` into ``--out`` (default ``test-artifacts/screenshots``), each
as tall as its page. Prints each file with the page's scroll width, which must not exceed
the window's.
"""

from __future__ import annotations

import argparse
import base64
import shutil
import sys
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
WIDTHS = (1280, 1920)


def _driver(chromium: str, driver: str) -> Any:
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = chromium
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--hide-scrollbars", "--window-size=1280,900"):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(executable_path=driver), options=options)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--site", type=Path, default=REPO / "leaderboards" / "site")
    parser.add_argument("--out", type=Path, default=REPO / "test-artifacts" / "screenshots")
    args = parser.parse_args(argv)
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if chromium is None or driver is None:
        print("needs headless Chromium: apt-get install chromium chromium-driver",
              file=sys.stderr)
        return 2
    site = args.site.resolve()
    if not (site / "index.html").is_file():
        print(f"{site} has no index.html; build it with `nsrmp-bench leaderboard`",
              file=sys.stderr)
        return 2
    pages = [site / "index.html", *sorted(p for p in site.glob("*.html")
                                          if p.name != "index.html")]
    cards = sorted(site.glob("cards/*.html"))
    pages += cards[:1] + [c for c in cards if "gives no facts" in c.read_text("utf-8")][:1]
    args.out.mkdir(parents=True, exist_ok=True)
    browser = _driver(chromium, driver)
    browser.set_page_load_timeout(120)
    try:
        for width in WIDTHS:
            for page in pages:
                browser.set_window_size(width, 900)
                browser.get(page.as_uri())
                height, scroll = browser.execute_script(
                    "return [document.documentElement.scrollHeight,"
                    " document.documentElement.scrollWidth];")
                name = page.relative_to(site).with_suffix("").as_posix().replace("/", "--")
                shot = args.out / f"{name}-{width}.png"
                # the whole page through the DevTools protocol: no window as tall as the
                # page, which a loaded machine's renderer may not paint in time
                data = browser.execute_cdp_cmd("Page.captureScreenshot", {
                    "format": "png", "captureBeyondViewport": True,
                    "clip": {"x": 0, "y": 0, "width": width, "height": int(height),
                             "scale": 1}})
                shot.write_bytes(base64.b64decode(data["data"]))
                print(f"{shot}  (scroll width {scroll} at {width} px)")
    finally:
        browser.quit()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
