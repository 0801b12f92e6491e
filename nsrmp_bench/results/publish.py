"""Rebuilding the leaderboards together with their static site.

:func:`publish` scores every entry once (with the per-category breakdown), writes the
Markdown and JSON boards exactly as :func:`nsrmp_bench.leaderboard.build` does, and then
fills the site folder (default ``leaderboards/site/``): ``summary.json`` of the entries'
runs (the format ``evaluate`` writes, so ``plot`` and ``report`` read it), the figures
(``figures/*.png``/``.svg``), the paper's tables (``paper-tables.md``/``.tex``) and the
pages, with copies of the model cards they link; the pages link the predictions files
where they are committed (``../predictions/``). The README's
Results figures are the site's figures. :func:`rebuild_site` redraws the site alone from
the committed boards and ``summary.json`` (no data, no scoring).
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Any

from nsrmp_bench._optional import require
from nsrmp_bench.leaderboard import Entry, build, load_entries
from nsrmp_bench.results.figures import draw_figures
from nsrmp_bench.results.paper_tables import write_report
from nsrmp_bench.results.site import read_boards, read_robustness, write_site
from nsrmp_bench.results.summary import Results, Run
from nsrmp_bench.scoring.result import ScoreResult

__all__ = ["publish", "rebuild_site", "write_site_files"]


def write_site_files(results: Results, entries_dir: str | os.PathLike[str],
                     boards_dir: str | os.PathLike[str],
                     site_dir: str | os.PathLike[str]) -> list[Path]:
    """Summary, figures, paper tables and pages of the site, from runs and board files."""
    site = Path(site_dir)
    results.write(site)
    written = draw_figures(results, site / "figures", none_ok=True)
    written += list(write_report(results, site, paper=True))
    written += write_site(read_boards(boards_dir), load_entries(entries_dir), site, results,
                          read_robustness(boards_dir))
    return written


def rebuild_site(entries_dir: str | os.PathLike[str], boards_dir: str | os.PathLike[str],
                 site_dir: str | os.PathLike[str]) -> list[Path]:
    """The site again from the boards of ``boards_dir`` and the runs of
    ``site_dir/summary.json``, as the last :func:`publish` wrote them (no scoring)."""
    require("matplotlib")
    runs = Results.read(site_dir).runs
    linked = tuple(replace(r, predictions=_beside_site(Path(r.predictions).name))
                   for r in runs)  # the committed files, wherever the summary pointed
    return write_site_files(Results(linked), entries_dir, boards_dir, site_dir)


def _beside_site(name: str) -> str:
    """A predictions file's path in ``summary.json``: relative to the site folder."""
    return f"../predictions/{name}"


def publish(entries_dir: str | os.PathLike[str], data_root: str | os.PathLike[str],
            out_dir: str | os.PathLike[str],
            site_dir: str | os.PathLike[str] | None = None,
            ) -> tuple[dict[str, list[dict[str, Any]]], list[Path]]:
    """Boards into ``out_dir`` and the site into ``site_dir`` (default ``out_dir/site``)."""
    require("matplotlib")  # before minutes of scoring, not after
    site = Path(site_dir) if site_dir is not None else Path(out_dir) / "site"
    runs: list[Run] = []

    def keep(entry: Entry, result: ScoreResult) -> None:
        runs.append(Run.from_score(result, model=entry.model, kind=entry.kind,
                                   predictions=_beside_site(entry.predictions.name)))

    boards = build(entries_dir, data_root, out_dir, breakdown=True, on_result=keep)
    return boards, write_site_files(Results(tuple(runs)), entries_dir, out_dir, site)
