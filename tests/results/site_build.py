"""Builds the static site from the committed boards, entries and runs into a temporary
``leaderboards/`` that mirrors the repository's layout, so that every link resolves and the
pages are byte-comparable with the committed ones."""

from __future__ import annotations

import shutil
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
BOARDS = REPO / "leaderboards"
SITE = BOARDS / "site"


def mirror(tmp: Path) -> Path:
    """tmp/leaderboards/{entries, *.json boards, robustness boards (copies), predictions
    (link)} and
    tmp/reference_model (link); returns tmp/leaderboards."""
    boards = tmp / "leaderboards"
    shutil.copytree(BOARDS / "entries", boards / "entries")
    for board in BOARDS.glob("*.json"):
        shutil.copy(board, boards / board.name)
    (boards / "predictions").symlink_to(BOARDS / "predictions", target_is_directory=True)
    if (BOARDS / "robustness").is_dir():
        shutil.copytree(BOARDS / "robustness", boards / "robustness")
    (tmp / "reference_model").symlink_to(REPO / "reference_model", target_is_directory=True)
    return boards


def build_site(tmp: Path, *, figures: bool = True) -> Path:
    """The site of the committed runs (``leaderboards/site/summary.json``) in ``tmp``:
    redrawn whole as ``nsrmp-bench leaderboard --site-only`` does, or (``figures=False``)
    the pages beside copies of the committed figures."""
    from nsrmp_bench.leaderboard import load_entries
    from nsrmp_bench.results.site import read_boards, read_robustness, write_site
    from nsrmp_bench.results.summary import Results

    boards = mirror(tmp)
    site = boards / "site"
    results = Results.read(SITE)
    if figures:
        from nsrmp_bench.results.publish import rebuild_site

        site.mkdir(parents=True)
        results.write(site)
        rebuild_site(boards / "entries", boards, site)
        return site
    # the pages only, beside copies of the committed figures and tables
    shutil.copytree(SITE / "figures", site / "figures")
    for name in ("paper-tables.md", "paper-tables.tex"):
        shutil.copy(SITE / name, site / name)
    write_site(read_boards(boards), load_entries(boards / "entries"), site, results,
               read_robustness(boards))
    return site
