"""The static web leaderboard: ``leaderboards/site/``, opened from ``file://``.

Pages are written from files only: the JSON boards (``leaderboards/<split>-<part>.json``),
the entry files (predictions path, model card) and the figures already drawn into
``site/figures/``. So the site is recomputable exactly like the Markdown boards, and the
same boards give the same bytes. There is no server and nothing is fetched: the style
sheet and the sorting script are copied next to the pages.

* ``index.html``: every board with its top entry, the generalisation figures, and the
  paper's tables (``paper-tables.md``/``.tex``) when present;
* ``<split>-<part>.html``: the board as a sortable table (IoU-M first, values with 95%
  intervals; a column heading sorts by its value), each entry linked to its predictions
  file and its model card, and the figures that involve the split;
* ``cards/<entry>.html``: the model card of an entry: training data, training time,
  parameters, supervision, the inputs it reads (:mod:`nsrmp_bench.results.model_cards`).

Each table row carries ``data-entry`` and each figure cell its exact value in
``data-value`` (the JSON board's number), which the browser test compares with the boards.
"""

from __future__ import annotations

import html
import json
import os
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.leaderboard import COLUMNS, Entry
from nsrmp_bench.results.figures import CATEGORY_BARS, FIGURES
from nsrmp_bench.results.model_cards import CARD_FIELDS, model_card
from nsrmp_bench.scoring.metrics import METRICS
from nsrmp_bench.storage.atomic import atomic_write_text

__all__ = ["ASSETS", "FIGURE_CAPTIONS", "read_boards", "write_site"]

ASSETS = ("site.css", "site.js")
FIGURE_CAPTIONS = {
    "iou_m_by_objects": "IoU-M against the number of objects: paper-v2/test (3–5, the "
                        "training range) then objects-v2/test (6–15); bands are 95% "
                        "bootstrap intervals.",
    "iou_m_by_steps": "IoU-M against the number of steps: paper-v2/test (1–2) then "
                      "steps-v2/test (3–7); bands are 95% bootstrap intervals.",
    "iou_m_by_category": "IoU-M per category of paper-v2/test, then the held-out "
                         "language (language-v2/test) and attribute pairs "
                         "(attributes-v2/test); bars show 95% intervals.",
}
_LABELS = {m.name: m.label for m in METRICS}


def read_boards(boards_dir: str | os.PathLike[str]) -> dict[str, list[dict[str, Any]]]:
    """Every JSON board of ``boards_dir`` (``<split>-<part>.json``), by split part."""
    boards: dict[str, list[dict[str, Any]]] = {}
    for path in sorted(Path(boards_dir).glob("*.json")):
        try:
            data = json.loads(path.read_text("utf-8"))
            boards[str(data["split"])] = list(data["rows"])
        except (OSError, ValueError, KeyError, TypeError) as exc:
            msg = (f"{path} is not a leaderboard board ({exc!r}); boards are written by "
                   "`nsrmp-bench leaderboard --data ROOT`: rebuild them")
            raise InvalidArgument(msg) from exc
    return boards


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def _stem(split: str) -> str:
    return split.replace("/", "-")


def _link(target: Path, start: Path) -> str:
    return Path(os.path.relpath(target, start)).as_posix()


def _page(title: str, body: list[str], depth: int = 0) -> str:
    up = "../" * depth
    return "\n".join([
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_e(title)}</title>",
        f'<link rel="stylesheet" href="{up}site.css">',
        "</head>",
        "<body>",
        *body,
        f'<script src="{up}site.js"></script>',
        "</body>",
        "</html>",
        "",
    ])


def _nav(splits: Sequence[str], depth: int = 0) -> str:
    up = "../" * depth
    links = [f'<a href="{up}index.html">all boards</a>']
    links += [f'<a href="{up}{_stem(s)}.html">{_e(s)}</a>' for s in splits]
    return "<nav>" + " ".join(links) + "</nav>"


def _metric_cell(triple: Any) -> str:
    value, low, high = (triple if isinstance(triple, list | tuple) else (None, None, None))
    if value is None:
        return '<td data-value="">–</td>'
    ci = f' <span class="ci">[{low:.3f}, {high:.3f}]</span>' if low is not None else ""
    return f'<td data-value="{value!r}">{value:.3f}{ci}</td>'


def _figures(names: Sequence[str], site: Path, start: Path) -> list[str]:
    out = []
    for name in names:
        png = site / "figures" / f"{name}.png"
        if not png.is_file():
            continue
        svg = png.with_suffix(".svg")
        alt = FIGURE_CAPTIONS[name]
        extra = f' (<a href="{_link(svg, start)}">SVG</a>)' if svg.is_file() else ""
        out += [
            "<figure>",
            f'<img src="{_link(png, start)}" alt="{_e(alt)}">',
            f"<figcaption>{_e(alt)}{extra}</figcaption>",
            "</figure>",
        ]
    return out


def _figures_for(split: str) -> list[str]:
    names = [a.name for a in FIGURES if split in (a.in_distribution, a.held_out)]
    if split in {part for _, part, _, _ in CATEGORY_BARS}:
        names.append("iou_m_by_category")
    return names


def _board_page(split: str, rows: list[dict[str, Any]], entries: Mapping[str, Entry],
                site: Path, splits: Sequence[str]) -> str:
    head = ['<th data-type="number">rank</th>', '<th data-type="text">model</th>',
            '<th data-type="text">kind</th>']
    head += [f'<th data-type="number" data-metric="{m}">{_e(_LABELS.get(m, m))}</th>'
             for m in COLUMNS]
    head += ['<th data-type="number">n</th>', '<th data-type="none">predictions</th>',
             '<th data-type="none">model card</th>']
    body = [
        _nav(splits),
        f"<h1>Leaderboard: {_e(split)}</h1>",
        '<p class="note">Every row is the public scorer\'s output on the committed '
        "predictions file (<code>nsrmp-bench leaderboard</code> recomputes it). Values with "
        "95% bootstrap intervals; IoU-M (moved objects) is the headline. Click a column "
        "heading to sort.</p>",
        '<table class="sortable" id="board">',
        "<thead><tr>" + "".join(head) + "</tr></thead>",
        "<tbody>",
    ]
    for rank, row in enumerate(rows, 1):
        entry = entries.get(row["entry"])
        if entry is None:
            msg = (f"board {split} has a row for entry {row['entry']!r}, which is not in the "
                   "entries folder; rebuild the boards with `nsrmp-bench leaderboard`")
            raise InvalidArgument(msg)
        cells = [f'<td data-value="{rank}">{rank}</td>',
                 f'<td class="text" title="{_e(row["description"])}">{_e(row["model"])}</td>',
                 f'<td class="text">{_e(row["kind"])}</td>']
        cells += [_metric_cell(row["metrics"].get(m)) for m in COLUMNS]
        cells.append(f'<td data-value="{int(row["n"])}">{int(row["n"])}</td>')
        cells.append(f'<td class="text"><a href="{_link(entry.predictions, site)}" '
                     f'title="{_e(entry.predictions.name)}">{_e(entry.predictions.suffix[1:])}</a></td>')
        cells.append(f'<td class="text"><a href="cards/{_e(entry.name)}.html">card</a></td>')
        kind = "baseline" if row["kind"] == "baseline" else "entry"
        body.append(f'<tr class="{kind}" data-entry="{_e(row["entry"])}">' + "".join(cells)
                    + "</tr>")
    body += ["</tbody>", "</table>"]
    figures = _figures(_figures_for(split), site, site)
    if figures:
        body += ["<h2>Figures</h2>", *figures]
    return _page(f"nsrmp-bench leaderboard: {split}", body)


def _card_page(entry: Entry, site: Path, splits: Sequence[str]) -> str:
    card = model_card(entry.model, entry.card)
    folder = site / "cards"
    facts = []
    for key, label in CARD_FIELDS:
        facts += [f"<dt>{_e(label)}</dt>", f"<dd>{_e(card.facts[key])}</dd>"]
    links = [f'<li>predictions: <a href="{_link(entry.predictions, folder)}">'
             f"{_e(entry.predictions.name)}</a></li>"]
    if entry.model_card is not None:
        links.append(f'<li>full model card: <a href="{_link(entry.model_card, folder)}">'
                     f"{_e(entry.model_card.name)}</a></li>")
    links.append(f'<li>board: <a href="../{_stem(entry.split)}.html">{_e(entry.split)}</a>'
                 "</li>")
    body = [
        _nav(splits, depth=1),
        f"<h1>Model card: {_e(entry.model)} on {_e(entry.split)}</h1>",
        f"<p>{_e(entry.description)} (kind: {_e(entry.kind)})</p>",
        '<dl class="card">', *facts, "</dl>",
        f'<p class="note">Facts from {_e(card.source)}.</p>',
        "<ul>", *links, "</ul>",
    ]
    return _page(f"model card: {entry.name}", body, depth=1)


def _index_page(boards: Mapping[str, list[dict[str, Any]]], site: Path) -> str:
    splits = list(boards)
    body = [
        _nav(splits),
        "<h1>nsrmp-bench leaderboards</h1>",
        '<p class="note">Generated by <code>nsrmp-bench leaderboard --data ROOT</code> from '
        "<code>leaderboards/entries/</code>; every number is the public scorer's output on a "
        "committed predictions file. It opens from disk: no server, nothing fetched.</p>",
        '<table class="sortable" id="boards">',
        '<thead><tr><th data-type="text">split part</th><th data-type="number">entries</th>'
        '<th data-type="text">top entry</th><th data-type="number">top IoU-M</th></tr></thead>',
        "<tbody>",
    ]
    for split, rows in boards.items():
        top = rows[0]
        body.append(
            f'<tr data-split="{_e(split)}"><td class="text"><a href="{_stem(split)}.html">'
            f"{_e(split)}</a></td>"
            f'<td data-value="{len(rows)}">{len(rows)}</td>'
            f'<td class="text">{_e(top["model"])}</td>'
            + _metric_cell(top["metrics"].get("iou_m")) + "</tr>")
    body += ["</tbody>", "</table>"]
    figures = _figures(list(FIGURE_CAPTIONS), site, site)
    if figures:
        body += ["<h2>Generalisation</h2>", *figures]
    tables = [p for p in (site / "paper-tables.md", site / "paper-tables.tex") if p.is_file()]
    if tables:
        links = ", ".join(f'<a href="{p.name}">{p.name}</a>' for p in tables)
        body += ["<h2>The paper's tables</h2>",
                 f"<p>Table I and Table II in the paper's layout, the paper's numbers beside "
                 f"ours: {links} (<code>nsrmp-bench report leaderboards/site --paper</code>)."
                 "</p>"]
    return _page("nsrmp-bench leaderboards", body)


def write_site(boards: Mapping[str, list[dict[str, Any]]], entries: Sequence[Entry],
               site_dir: str | os.PathLike[str]) -> list[Path]:
    """Write the pages and assets of ``boards`` into ``site_dir``; returns the pages."""
    if not boards:
        msg = "no boards to put on the site; build them with `nsrmp-bench leaderboard`"
        raise InvalidArgument(msg)
    site = Path(os.path.normpath(Path(site_dir).absolute()))
    (site / "cards").mkdir(parents=True, exist_ok=True)
    assets = resources.files("nsrmp_bench.results")
    for name in ASSETS:
        atomic_write_text(site / name, assets.joinpath(name).read_text("utf-8"))
    by_name = {e.name: e for e in entries}
    splits = sorted(boards)
    ordered = {s: boards[s] for s in splits}
    pages = [site / "index.html"]
    atomic_write_text(pages[0], _index_page(ordered, site))
    for split in splits:
        page = site / f"{_stem(split)}.html"
        atomic_write_text(page, _board_page(split, ordered[split], by_name, site, splits))
        pages.append(page)
    on_boards = {row["entry"] for rows in ordered.values() for row in rows}
    for entry in entries:
        if entry.name in on_boards:
            page = site / "cards" / f"{entry.name}.html"
            atomic_write_text(page, _card_page(entry, site, splits))
            pages.append(page)
    return pages
