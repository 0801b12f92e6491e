"""The static web leaderboard: ``leaderboards/site/``, opened from ``file://``.

Pages are written from files only: the JSON boards (``leaderboards/<split>-<part>.json``),
the entry files (predictions path, model card), the scored runs (``summary.json``: the
scorer's counts say each row's protocol) and the figures already drawn into
``site/figures/``. So the site is recomputable exactly like the Markdown boards, and the
same boards give the same bytes. There is no server and nothing is fetched: the style
sheet and the sorting script are copied next to the pages, and so is every model card
(``model-cards/``) a page links. The predictions files are linked where they are committed,
``../predictions/`` beside the site (a relative link, valid in the repository and in a
published copy of ``leaderboards/``), not copied; a site written outside the folder that
holds the predictions (``--site DIR`` elsewhere, to publish the site alone) gets copies in
``DIR/predictions/``.

* ``index.html``: every leaderboard with its best entry (reference rows aside), the
  generalisation figures and the paper's tables (``paper-tables.md``/``.tex``) when
  present; the test boards (smoke) apart, below;
* ``<split>-<part>.html``: the board as a sortable table (IoU-M first, values with 95%
  intervals; a column heading sorts by its value), a protocol column and a filter by
  protocol, each entry linked to its predictions file and its model card, and the
  figures that involve the split;
* ``cards/<entry>.html``: the model card of an entry: training data, training time,
  parameters, supervision, the inputs it reads (:mod:`nsrmp_bench.results.model_cards`),
  or, plainly, that its card states none of them; and the protocol fields the entry states
  (supervision, boxes, training parts, seeds, scorer, manifest root hash), which the
  board's protocol cell also shows on hover.

Ranks (:func:`shared_ranks`, the rule is :data:`RANK_RULE`, printed on every board): the
reference rows are not ranked; the other entries are ranked by IoU-M, and one whose 95%
interval overlaps the interval of the first entry of its tie group (the leader) shares
the leader's rank.

Each table row carries ``data-entry`` and each figure cell its exact value in
``data-value`` (the JSON board's number), which the browser test compares with the boards.
"""

from __future__ import annotations

import html
import json
import os
import shutil
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.leaderboard import COLUMNS, Entry, scorer_note
from nsrmp_bench.ranks import RANK_RULE, rank_metric, rank_rule, shared_ranks
from nsrmp_bench.results.colours import model_styles
from nsrmp_bench.results.figures import CATEGORY_BARS, FIGURES, caption, figure_names
from nsrmp_bench.results.model_cards import CARD_FIELDS, NOT_STATED, model_card
from nsrmp_bench.results.protocols import PROTOCOLS, Protocol, is_reference, protocol_of
from nsrmp_bench.results.robustness_table import Suite, read_suite
from nsrmp_bench.results.summary import Results
from nsrmp_bench.scoring.metrics import METRICS_V2
from nsrmp_bench.storage.atomic import atomic_write_text

__all__ = ["ASSETS", "RANK_RULE", "ROBUSTNESS_DIR", "is_test_board", "read_boards",
           "read_robustness", "shared_ranks", "write_site"]

ASSETS = ("site.css", "site.js")
_LABELS = {m.name: m.label for m in METRICS_V2}


def is_test_board(split: str) -> bool:
    """Whether a board is a test board (the smoke split: a few instances, for checking a
    pipeline, not for comparing models)."""
    return split.split("-v", 1)[0] == "smoke"


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


def _model_name(model: str) -> str:
    return "+<wbr>".join(_e(part) for part in model.split("+"))


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
    links += [f'<a href="{up}{_stem(s)}.html">{_e(s)}</a>' for s in splits
              if not is_test_board(s)]
    tests = [f'<a class="test" href="{up}{_stem(s)}.html">test board: {_e(s)}</a>'
             for s in splits if is_test_board(s)]
    return "<nav>" + " ".join(links + tests) + "</nav>"


def _metric_cell(triple: object) -> str:
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
        alt = caption(name)
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
    return names or [f"{name}--{_stem(split)}" for name in figure_names()]


class _Site:
    """The site folder, the entries by name, the protocols and the copied files."""

    def __init__(self, site: Path, entries: Sequence[Entry], results: Results | None,
                 splits: Sequence[str]) -> None:
        self.root = site
        self.entries = {e.name: e for e in entries}
        self.splits = splits
        self.results = results
        models = [e.model for e in entries if not is_reference(e.kind)]
        self.styles = model_styles(models)

    def protocol(self, entry: Entry) -> Protocol | None:
        run = self.results.run(entry.model, entry.split) if self.results is not None else None
        return protocol_of(entry.model, run.counts) if run is not None else None

    def entry(self, split: str, name: str) -> Entry:
        found = self.entries.get(name)
        if found is None:
            msg = (f"board {split} has a row for entry {name!r}, which is not in the "
                   "entries folder; rebuild the boards with `nsrmp-bench leaderboard`")
            raise InvalidArgument(msg)
        return found

    def predictions(self, entry: Entry) -> Path:
        """The entry's predictions file as the pages link it: the committed file when it
        lies in the folder that holds the site (``leaderboards/predictions/``), else the
        site's own copy (copied on first use)."""
        if entry.predictions.is_relative_to(self.root.parent) and \
                not entry.predictions.is_relative_to(self.root):
            if not entry.predictions.is_file():
                msg = (f"{entry.predictions} does not exist; the site links it from "
                       f"{self.root}: restore it")
                raise InvalidArgument(msg)
            return entry.predictions
        return _copy(entry.predictions, self.root / "predictions" / entry.predictions.name)

    def full_card(self, entry: Entry) -> Path | None:
        """The site's copy of the entry's model card file, if it names one."""
        if entry.model_card is None:
            return None
        return _copy(entry.model_card, self.root / "model-cards" / entry.model_card.parent.name
                     / entry.model_card.name)

    def swatch(self, model: str) -> str:
        style = self.styles.get(model)
        if style is None:
            return '<span class="swatch ref" aria-hidden="true"></span>'
        return (f'<span class="swatch" style="background:{style.colour}" '
                'aria-hidden="true"></span>')


def _copy(source: Path, target: Path) -> Path:
    if not source.is_file():
        msg = f"{source} does not exist; the site copies it to {target}: restore it"
        raise InvalidArgument(msg)
    if target.is_file() and target.read_bytes() == source.read_bytes():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(target.name + ".tmp")
    shutil.copyfile(source, tmp)
    tmp.replace(target)
    return target


def _filters(protocols: Sequence[str]) -> str:
    boxes = [f'<label><input type="checkbox" data-filter="protocol" value="{_e(p)}" checked> '
             f"{_e(p)}</label>" for p in protocols]
    boxes.append('<label><input type="checkbox" data-filter="reference" value="reference" '
                 "checked> reference rows (oracle, noop, random)</label>")
    return ('<fieldset class="filters" data-table="board"><legend>show</legend>'
            + " ".join(boxes) + "</fieldset>")


def _board_page(split: str, rows: list[dict[str, Any]], site: _Site) -> str:
    head = ['<th data-type="number">rank</th>', '<th data-type="text">model</th>',
            '<th data-type="text">kind</th>', '<th data-type="text">protocol</th>']
    head += [f'<th data-type="number" data-metric="{m}">{_e(_LABELS.get(m, m))}</th>'
             for m in COLUMNS]
    head += ['<th data-type="number">n</th>', '<th data-type="none">files</th>']
    test = is_test_board(split)
    title = f"Test board: {split}" if test else f"Leaderboard: {split}"
    body = [_nav(site.splits), f"<h1>{_e(title)}</h1>"]
    if test:
        body.append('<p class="warning">A test board: this part has a handful of '
                    "instances, for checking that a pipeline runs end to end. Its numbers "
                    "compare nothing; the leaderboards are the official test parts.</p>")
    body += [
        '<p class="note">Every row is the public scorer\'s output on the committed '
        "predictions file (<code>nsrmp-bench leaderboard</code> recomputes it). Values with "
        "95% bootstrap intervals; IoU-M (moved objects) is the headline. Click a column "
        "heading to sort; the boxes below filter by protocol.</p>",
        f'<p class="note">{_e(rank_rule(rank_metric(rows)))}</p>',
    ]
    scorers = sorted({str(r["scorer"]) for r in rows if r.get("scorer")})
    if scorers:
        body.append(f'<p class="note">{_e(scorer_note(", ".join(scorers)))}</p>')
    protocols: list[Protocol | None] = [site.protocol(site.entry(split, r["entry"]))
                                        for r in rows]
    present = [p for p in PROTOCOLS if any(q is not None and q.name == p for q in protocols)]
    if present:
        body.append(_filters(present))
    body += ['<table class="sortable" id="board">',
             "<thead><tr>" + "".join(head) + "</tr></thead>", "<tbody>"]
    for row, rank, protocol in zip(rows, shared_ranks(rows), protocols, strict=True):
        entry = site.entry(split, row["entry"])
        reference = is_reference(row["kind"])
        predictions = site.predictions(entry)
        rank_cell = (f'<td data-value="{rank.rstrip("=")}">{rank}</td>' if rank
                     else '<td data-value="" title="reference row: not ranked">ref</td>')
        cells = [rank_cell,
                 f'<td class="text model" title="{_e(row["description"])}">'
                 f'{site.swatch(row["model"])}{_model_name(row["model"])}</td>',
                 f'<td class="text">{_e(row["kind"])}</td>',
                 f'<td class="text"{_stated_title(entry)}>'
                 f'{_e(protocol.label if protocol else "not scored here")}</td>']
        cells += [_metric_cell(row["metrics"].get(m)) for m in COLUMNS]
        cells.append(f'<td data-value="{int(row["n"])}">{int(row["n"])}</td>')
        cells.append(f'<td class="text files"><a href="{_link(predictions, site.root)}" '
                     f'title="{_e(predictions.name)}">predictions</a><br>'
                     f'<a href="cards/{_e(entry.name)}.html">card</a></td>')
        kind = "baseline" if reference else "entry"
        data_protocol = f' data-protocol="{_e(protocol.name)}"' if protocol else ""
        body.append(f'<tr class="{kind}" data-entry="{_e(row["entry"])}"{data_protocol}>'
                    + "".join(cells) + "</tr>")
    body += ["</tbody>", "</table>"]
    figures = _figures(_figures_for(split), site.root, site.root)
    if figures:
        body += ["<h2>Figures</h2>", *figures]
    return _page(f"nsrmp-bench {'test board' if test else 'leaderboard'}: {split}", body)


def _stated(entry: Entry) -> list[tuple[str, str]]:
    """The protocol fields the entry states, as (label, text) pairs; [] when none."""
    if entry.protocol is None:
        return []
    p = entry.protocol
    return [("supervision", p.supervision), ("boxes", p.boxes),
            ("training parts", ", ".join(p.training_parts) or "none"),
            ("seeds", ", ".join(map(str, p.seeds)) or "none"), ("scorer", p.scorer),
            ("manifest root hash", p.manifest_root_hash)]


def _stated_title(entry: Entry) -> str:
    """A ``title`` attribute listing the stated protocol (the board's hover text)."""
    stated = _stated(entry)
    if not stated:
        return ' title="this entry states no protocol fields"'
    text = "; ".join(f"{k}: {v[:16] + '...' if k.startswith('manifest') else v}"
                     for k, v in stated)
    return f' title="{_e(text)}"'


def _protocol_section(entry: Entry) -> list[str]:
    """The card page's list of the protocol fields the entry states."""
    stated = _stated(entry)
    if not stated:
        return ["<h2>Protocol</h2>", '<p class="warning">This entry states no protocol '
                "fields (supervision, boxes, training parts, seeds, scorer, manifest).</p>"]
    rows = [f"<dt>{_e(k)}</dt><dd>{_e(v)}</dd>" for k, v in stated]
    return ["<h2>Protocol</h2>", '<dl class="card protocol">', *rows, "</dl>",
            '<p class="note">Stated in the entry file and checked when the boards are built: '
            "the manifest root hash is the one of the part the predictions were made on, "
            "the scorer the one that scores them.</p>"]


def _card_page(entry: Entry, site: _Site) -> str:
    card = model_card(entry.model, entry.card)
    folder = site.root / "cards"
    unstated = [label for key, label in CARD_FIELDS if card.facts[key] == NOT_STATED]
    facts = []
    for key, label in CARD_FIELDS:
        facts += [f"<dt>{_e(label)}</dt>", f"<dd>{_e(card.facts[key])}</dd>"]
    predictions = site.predictions(entry)
    links = [f'<li>predictions: <a href="{_link(predictions, folder)}">'
             f"{_e(predictions.name)}</a></li>"]
    full = site.full_card(entry)
    if full is not None:
        links.append(f'<li>full model card: <a href="{_link(full, folder)}">'
                     f"{_e(full.name)}</a></li>")
    links.append(f'<li>board: <a href="../{_stem(entry.split)}.html">{_e(entry.split)}</a>'
                 "</li>")
    protocol = site.protocol(entry)
    body = [
        _nav(site.splits, depth=1),
        f"<h1>Model card: {_e(entry.model)} on {_e(entry.split)}</h1>",
        f"<p>{_e(entry.description)} (kind: {_e(entry.kind)}"
        + (f"; protocol: {_e(protocol.label)}" if protocol else "") + ")</p>",
    ]
    if len(unstated) == len(CARD_FIELDS):
        body.append('<p class="warning">This entry\'s card gives no facts: its training '
                    "data, training time, parameters, supervision and inputs are not "
                    "stated, so nothing on this page says how the model was made. A "
                    "submitter states them under <code>\"card\"</code> in the entry file "
                    "(README, “How to submit”).</p>")
    else:
        note = f"Facts from {card.source}."
        if unstated:
            note += " Not stated: " + ", ".join(unstated) + "."
        body += ['<dl class="card">', *facts, "</dl>", f'<p class="note">{_e(note)}</p>']
    body += _protocol_section(entry)
    body += ["<ul>", *links, "</ul>"]
    return _page(f"model card: {entry.name}", body, depth=1)


def _board_rows(title: str, boards: Mapping[str, list[dict[str, Any]]], site: _Site,
                table_id: str) -> list[str]:
    out = [
        f'<table class="sortable" id="{table_id}">',
        '<thead><tr><th data-type="text">split part</th><th data-type="number">entries</th>'
        '<th data-type="text">best entry (reference rows aside)</th>'
        '<th data-type="text">protocol</th><th data-type="number">its IoU-M</th>'
        "</tr></thead>",
        "<tbody>",
    ]
    for split, rows in boards.items():
        ranks = shared_ranks(rows)
        ranked = [(r, k) for r, k in zip(rows, ranks, strict=True) if k]
        cells = [f'<td class="text"><a href="{_stem(split)}.html">{_e(split)}</a></td>',
                 f'<td data-value="{len(rows)}">{len(rows)}</td>']
        if ranked:
            best, rank = ranked[0]
            tied = [r["model"] for r, k in ranked[1:] if k == rank]
            also = (f' <span class="tie">shares rank 1 with {_e(", ".join(tied))}</span>'
                    if tied else "")
            protocol = site.protocol(site.entry(split, best["entry"]))
            cells += [f'<td class="text">{site.swatch(best["model"])}'
                      f'{_model_name(best["model"])}{also}</td>',
                      f'<td class="text">{_e(protocol.label if protocol else "")}</td>',
                      _metric_cell(best["metrics"].get("iou_m"))]
        else:
            cells += ['<td class="text">no entry but the reference rows</td>',
                      '<td class="text"></td>', '<td data-value="">–</td>']
        out.append(f'<tr data-split="{_e(split)}">' + "".join(cells) + "</tr>")
    out += ["</tbody>", "</table>"]
    return [f"<h2>{_e(title)}</h2>", *out] if title else out


def _index_page(boards: Mapping[str, list[dict[str, Any]]], site: _Site,
                robustness: bool = False) -> str:
    official = {s: r for s, r in boards.items() if not is_test_board(s)}
    tests = {s: r for s, r in boards.items() if is_test_board(s)}
    body = [
        _nav(site.splits),
        "<h1>nsrmp-bench leaderboards</h1>",
        '<p class="note">Generated by <code>nsrmp-bench leaderboard --data ROOT</code> from '
        "<code>leaderboards/entries/</code>; every number is the public scorer's output on a "
        "committed predictions file, linked from <code>leaderboards/predictions/</code>. It "
        "opens from disk and is published with the folder that holds it: no server, "
        "nothing fetched, every link inside <code>leaderboards/</code>.</p>",
        f'<p class="note">{_e(RANK_RULE)}</p>',
    ]
    if official:
        body += _board_rows("", official, site, "boards")
    if robustness:
        body += ["<h2>Robustness</h2>",
                 '<p>Each model on perturbed instructions (polite, filler, typo, synonym, '
                 'reorder, case) and the blind and shuffled controls: '
                 '<a href="robustness.html">the robustness boards</a>.</p>']
    figures = _figures([a.name for a in FIGURES] + ["iou_m_by_category"], site.root,
                       site.root)
    if figures:
        body += ["<h2>Generalisation</h2>", *figures]
    tables = [p for p in (site.root / "paper-tables.md", site.root / "paper-tables.tex")
              if p.is_file()]
    if tables:
        links = ", ".join(f'<a href="{p.name}">{p.name}</a>' for p in tables)
        body += ["<h2>The paper's tables</h2>",
                 f"<p>Table I and Table II in the paper's layout, the paper's numbers beside "
                 f"ours: {links} (<code>nsrmp-bench report leaderboards/site --paper</code>)."
                 "</p>"]
    if tests:
        body += ["<h2>Test boards</h2>",
                 '<p class="warning">Not leaderboards: a few instances each, to check that '
                 "a pipeline runs end to end (the README's first run uses smoke-v2).</p>",
                 *_board_rows("", tests, site, "test-boards")]
    return _page("nsrmp-bench leaderboards", body)


ROBUSTNESS_DIR = "robustness"
"""The robustness boards' folder in the boards folder (``nsrmp-bench robustness --board``)."""


def read_robustness(boards_dir: str | os.PathLike[str]) -> list[Suite]:
    """The robustness boards committed beside the boards (``robustness/*.json``)."""
    folder = Path(boards_dir) / ROBUSTNESS_DIR
    return [read_suite(p) for p in sorted(folder.glob("*.json"))]


def _interval_cell(text: str) -> str:
    """``+0.012 [-0.003, +0.020]`` as the figure above its interval (a narrow column)."""
    value, sep, interval = text.partition(" [")
    return _e(value) + (f"<br><small>[{_e(interval)}</small>" if sep else "")


def _robustness_page(suites: Sequence[Suite], splits: Sequence[str]) -> str:
    body = [_nav(splits), "<h1>Robustness</h1>",
            '<p class="note">Each model on perturbed copies of a test part (same scenes, '
            "ids and gold; other instruction texts): per kind, the paired IoU-M difference "
            "to the same model on the unperturbed part with its 95% interval; the controls "
            "(blind: an instruction that asks for nothing; shuffled: another episode's) as "
            "IoU-M. Made by <code>nsrmp-bench robustness ... --board "
            "leaderboards/robustness</code> with the suite's seed and word lists.</p>"]
    for suite in suites:
        head, rows = suite.table()
        cells = ["<tr>" + "".join(f'<td class="text">{_model_name(c)}</td>' if i == 0
                                  else f"<td>{_interval_cell(c)}</td>"
                                  for i, c in enumerate(row))
                 + "</tr>" for row in rows]
        body += [f"<h2>{_e(suite.split)} (suite seed {suite.seed})</h2>", "<table>",
                 "<thead><tr>" + "".join(f"<th>{_e(h)}</th>" for h in head) + "</tr></thead>",
                 "<tbody>", *cells, "</tbody>", "</table>"]
    return _page("Robustness", body)


def write_site(boards: Mapping[str, list[dict[str, Any]]], entries: Sequence[Entry],
               site_dir: str | os.PathLike[str], results: Results | None = None,
               robustness: Sequence[Suite] = ()) -> list[Path]:
    """Write the pages and assets of ``boards`` into ``site_dir``; returns the pages.

    ``results`` (the entries' scored runs) gives each row's protocol; without it the
    protocol column says "not scored here". The model cards the pages link are copied
    into ``site_dir``; the predictions files are linked where they are when they lie in
    ``site_dir``'s parent folder, else copied into ``site_dir/predictions/``.
    """
    if not boards:
        msg = "no boards to put on the site; build them with `nsrmp-bench leaderboard`"
        raise InvalidArgument(msg)
    root = Path(os.path.normpath(Path(site_dir).absolute()))
    (root / "cards").mkdir(parents=True, exist_ok=True)
    assets = resources.files("nsrmp_bench.results")
    for name in ASSETS:
        atomic_write_text(root / name, assets.joinpath(name).read_text("utf-8"))
    splits = sorted(boards, key=lambda s: (is_test_board(s), s))
    ordered = {s: boards[s] for s in splits}
    site = _Site(root, entries, results, splits)
    pages = [root / "index.html"]
    atomic_write_text(pages[0], _index_page(ordered, site, bool(robustness)))
    if robustness:
        pages.append(atomic_write_text(root / "robustness.html",
                                       _robustness_page(robustness, splits)))
    for split in splits:
        page = root / f"{_stem(split)}.html"
        atomic_write_text(page, _board_page(split, ordered[split], site))
        pages.append(page)
    on_boards = {row["entry"] for rows in ordered.values() for row in rows}
    for entry in entries:
        if entry.name in on_boards:
            page = root / "cards" / f"{entry.name}.html"
            atomic_write_text(page, _card_page(entry, site))
            pages.append(page)
    return pages
