"""Static, re-computable leaderboards.

A row is a data file ``leaderboards/entries/<name>.json`` naming a model, the split it was
run on and its predictions file (committed next to it, under ``leaderboards/predictions/``),
and stating its protocol (``"protocol"``: supervision, boxes, training parts, seeds, scorer,
the root hash of the part's manifest; :mod:`nsrmp_bench.scoring.protocol_fields`), which
:func:`build` checks against the data and the scorer.
:func:`build` scores every entry with the public scorer (:func:`nsrmp_bench.score`, exactly
as a submitter would) against the split's data and writes one board per split as Markdown
and JSON. Anyone with the data can rebuild the boards and get the same numbers.

An entry is untrusted (it arrives as a pull request): its ``predictions`` and
``model_card`` must be relative paths that stay inside the repository holding
``leaderboards/entries/`` (the entries folder's grandparent), with a predictions file's
suffix and a ``.md`` card, and the file itself no symbolic link; anything else is refused
with :class:`~nsrmp_bench.errors.UnsafePath`, so no entry can get another file of the
maintainer's machine copied into the published site.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.errors import InvalidArgument, UnsafePath
from nsrmp_bench.ranks import rank_metric, rank_rule, shared_ranks
from nsrmp_bench.scoring.gold import GoldTable, load_gold
from nsrmp_bench.scoring.protocol_fields import ProtocolFields, manifest_mismatch, part_root_hash
from nsrmp_bench.scoring.result import ScoreResult
from nsrmp_bench.scoring.scorer import score
from nsrmp_bench.scoring.version import KNOWN_SCORERS, SCORER_ID
from nsrmp_bench.storage.atomic import atomic_write_text
from nsrmp_bench.storage.manifest import read_manifest
from nsrmp_bench.storage.split_root import find_part

__all__ = ["COLUMNS", "PHENOMENON_COLUMNS", "Entry", "build", "load_entries",
           "render_markdown", "scorer_note"]

COLUMNS = ("iou_m", "iou", "success", "success_strict", "kept_still", "program_exact",
           "identification", "placement")
"""The metrics each board shows, headline first (strict success and kept still are
``scorer-v2``'s: what the prediction moved that the instruction leaves in place)."""


_PREDICTION_SUFFIXES = (".jsonl", ".jsonl.gz", ".parquet", ".json", ".ndjson", ".ndjson.gz")


def _beside(entry_file: Path, relative: str, key: str) -> Path:
    """``relative`` to the entry file's folder, absolute but with symlinks kept (the site
    links files by their place beside the entries, not where a link points); refused
    unless it stays inside the repository that holds the entries folder, is no link
    itself, and has the suffix its ``key`` needs."""
    repo = Path(os.path.normpath(entry_file.parent.parent.parent.absolute()))
    where = f"leaderboard entry {entry_file}: {key!r}"
    if Path(relative).is_absolute() or "\\" in relative:
        msg = (f"{where} is {relative!r}, an absolute path; expected a path relative to the "
               "entry file inside the repository (e.g. '../predictions/NAME.jsonl.gz')")
        raise UnsafePath(msg)
    path = Path(os.path.normpath((entry_file.parent / relative).absolute()))
    if not path.is_relative_to(repo):
        msg = (f"{where} is {relative!r}, which leads to {str(path)!r} outside the repository "
               f"{str(repo)!r}; commit the file inside it and name it relative to the entry")
        raise UnsafePath(msg)
    suffixes = (".md",) if key == "model_card" else _PREDICTION_SUFFIXES
    if not path.name.lower().endswith(suffixes):
        msg = (f"{where} is {relative!r}; expected a file ending in {' or '.join(suffixes)}: "
               "name the entry's " + ("model card (Markdown)" if key == "model_card"
                                      else "predictions file"))
        raise UnsafePath(msg)
    if path.is_symlink():
        msg = (f"{where} is {relative!r}, a symbolic link (to {os.readlink(path)!r}); commit "
               "the file itself")
        raise UnsafePath(msg)
    return path


@dataclass(frozen=True)
class Entry:
    """One leaderboard row as submitted."""

    name: str
    model: str
    split: str
    predictions: Path
    kind: str
    description: str
    model_card: Path | None = None
    card: dict[str, Any] = field(default_factory=dict)
    """Facts the entry states for its model card (see :mod:`nsrmp_bench.results.model_cards`)."""
    protocol: ProtocolFields | None = None
    """The protocol the entry states (None for an entry that states none)."""

    @classmethod
    def read(cls, path: Path) -> Entry:
        """Parse an entry file; a bad one names the key and the fix."""
        try:
            data = json.loads(path.read_text("utf-8"))
            entry = cls(
                name=path.stem,
                model=str(data["model"]),
                split=str(data["split"]),
                predictions=_beside(path, str(data["predictions"]), "predictions"),
                kind=str(data.get("kind", "submission")),
                description=str(data.get("description", "")),
                model_card=_beside(path, str(data["model_card"]), "model_card")
                if "model_card" in data else None,
                card=dict(data.get("card", {})),
            )
        except UnsafePath:
            raise
        except (OSError, ValueError, KeyError, TypeError) as exc:
            msg = (
                f"leaderboard entry {path} is unreadable or lacks a key ({exc}); an entry "
                "needs 'model', 'split' (e.g. paper-v2/test) and 'predictions' (a path "
                "relative to the entry file)"
            )
            raise InvalidArgument(msg) from exc
        if "protocol" in data:  # its own messages name the field and the fix
            entry = replace(entry, protocol=ProtocolFields.from_dict(data["protocol"], str(path)))
        if "/" not in entry.split:
            msg = f"{path}: split {entry.split!r} must name a part, e.g. 'paper-v2/test'"
            raise InvalidArgument(msg)
        if not entry.predictions.is_file():
            msg = f"{path}: predictions file {entry.predictions} does not exist"
            raise InvalidArgument(msg)
        return entry


def load_entries(entries_dir: str | os.PathLike[str]) -> list[Entry]:
    """Every entry file of ``entries_dir``, sorted by name."""
    d = Path(entries_dir)
    if not d.is_dir():
        msg = f"{d} is not a directory of leaderboard entries (*.json)"
        raise InvalidArgument(msg)
    return [Entry.read(p) for p in sorted(d.glob("*.json"))]


PHENOMENON_COLUMNS = ("program_exact", "success_strict", "kept_still", "abstention")
"""The figures a board of a part with phenomena (semantics-v1) shows per phenomenon."""


def _by_phenomenon(result: ScoreResult) -> dict[str, dict[str, list[float]]]:
    """Each phenomenon's value, interval and count of :data:`PHENOMENON_COLUMNS` (empty
    where the part records no phenomenon)."""
    cat = result.per_category
    rows = cat[(cat["category"] == "phenomenon") & cat["metric"].isin(PHENOMENON_COLUMNS)]
    out: dict[str, dict[str, list[float]]] = {}
    numbers = rows[["value", "ci_low", "ci_high", "n"]].to_numpy(dtype=float).tolist()
    for group, metric, figures in zip(rows["group"].tolist(), rows["metric"].tolist(),
                                      numbers, strict=True):
        out.setdefault(str(group), {})[str(metric)] = figures
    return out


def _phenomenon_table(rows: list[dict[str, Any]]) -> list[str]:
    """The board's second table: every row's figures per phenomenon."""
    phenomena = sorted({p for row in rows for p in row.get("phenomena", {})})
    if not phenomena:
        return []
    head = ["phenomenon", "model", *PHENOMENON_COLUMNS, "n"]
    lines = ["", "## By phenomenon", "",
             "Each phenomenon's instances (docs/semantics.md); abstention is defined where "
             "the gold abstains (\u2013 elsewhere).", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for phenomenon in phenomena:
        for row in rows:
            figures = row.get("phenomena", {}).get(phenomenon, {})
            cells = [phenomenon, row["model"]]
            cells += [_cell(*figures[m][:3]) if m in figures else "\u2013"
                      for m in PHENOMENON_COLUMNS]
            n = figures.get("program_exact", [0, 0, 0, 0])[3]
            lines.append("| " + " | ".join([*cells, str(int(n))]) + " |")
    return lines


def _cell(value: float, low: float, high: float) -> str:
    if math.isnan(value):
        return "–"
    if math.isnan(low):
        return f"{value:.3f}"
    return f"{value:.3f} [{low:.3f}, {high:.3f}]"


def scorer_note(scorer: str) -> str:
    """What a board says of the scorer its rows were scored with."""
    if "scorer-v2" not in scorer:  # a board scored before scorer-v2 has no such columns
        return f"Scored with {scorer}."
    return (f"Scored with {scorer}: success_strict is success with every object the gold "
            "leaves in place kept still (final box IoU >= 0.5 with gold), kept_still the "
            "share of those objects kept still.")


def render_markdown(split: str, rows: list[dict[str, Any]], scorer: str = SCORER_ID) -> str:
    """The Markdown board of one split."""
    head = ["rank", "model", "kind", *COLUMNS, "n"]
    lines = [
        f"# Leaderboard: {split}",
        "",
        "Generated by `nsrmp-bench leaderboard` from `leaderboards/entries/`; every row is "
        "the public scorer's output on the committed predictions file. Values with 95% "
        f"bootstrap intervals; IoU-M is the headline. {scorer_note(scorer)} "
        + rank_rule(rank_metric(rows)),
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for rank, row in zip(shared_ranks(rows), rows, strict=True):
        cells = [rank or "ref", row["model"], row["kind"]]
        cells += [_cell(*row["metrics"][m]) for m in COLUMNS]
        cells.append(str(row["n"]))
        lines.append("| " + " | ".join(cells) + " |")
    lines += _phenomenon_table(rows)
    return "\n".join(lines) + "\n"


def build(
    entries_dir: str | os.PathLike[str],
    data_root: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    breakdown: bool = False,
    on_result: Callable[[Entry, ScoreResult], None] | None = None,
    scorer: str = SCORER_ID,
) -> dict[str, list[dict[str, Any]]]:
    """Score every entry against ``data_root/<split id>/<part>`` (or ``<name>/<part>``,
    :func:`~nsrmp_bench.storage.split_root.find_part`) with ``scorer`` and write the boards
    (each says its scorer; an entry written for either known scorer is scored).

    ``on_result`` sees each entry's full result (with the per-category breakdown when
    ``breakdown``; the boards' figures are the same either way).
    """
    boards: dict[str, list[dict[str, Any]]] = {}
    golds: dict[str, tuple[GoldTable, bool]] = {}  # part -> its gold, has phenomena
    for entry in load_entries(entries_dir):
        split_id, part = entry.split.split("/", 1)
        data = find_part(data_root, entry.split)
        if data is None:
            msg = (
                f"no data for {entry.split} at {Path(data_root) / split_id / part}; "
                f"generate it first: "
                f"nsrmp-bench generate --split {split_id} --out {Path(data_root) / split_id}"
            )
            raise InvalidArgument(msg)
        _check_protocol(entry, data)
        if str(data) not in golds:  # a part's gold and manifest are read once for all its entries
            golds[str(data)] = (load_gold(data), "phenomenon" in
                                read_manifest(data).to_dict().get("counts", {}))
        gold, phenomena = golds[str(data)]
        result = score(entry.predictions, gold, breakdown=breakdown or phenomena, scorer=scorer)
        if on_result is not None:
            on_result(entry, result)
        metrics = {}
        for m in COLUMNS:
            value = result.value(m) if m in result.summary.index else float("nan")
            low, high = result.interval(m) if m in result.summary.index else (math.nan,) * 2
            metrics[m] = (value, low, high)
        boards.setdefault(entry.split, []).append({
            "entry": entry.name, "model": entry.model, "kind": entry.kind,
            "description": entry.description, "metrics": metrics,
            "n": int(str(result.summary.at["iou", "n"])), "scorer": result.scorer,
            **({"phenomena": _by_phenomenon(result)} if phenomena else {}),
        })
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for split, rows in boards.items():
        metric = rank_metric(rows)
        rows.sort(key=lambda r: (-r["metrics"][metric][0], r["model"]))
        stem = split.replace("/", "-")
        atomic_write_text(out / f"{stem}.md", render_markdown(split, rows, scorer))
        atomic_write_text(out / f"{stem}.json", canonical_json(
            {"split": split, "scorer": scorer, "rows": _nan_to_none(rows)}) + "\n")
    return boards


def _check_protocol(entry: Entry, data: Path) -> None:
    """An entry's stated protocol must name the part it is scored on and a known scorer
    (a file written for ``scorer-v1`` is scored by ``scorer-v2`` too: its figures keep
    their values)."""
    if entry.protocol is None:
        return
    root = part_root_hash(data)
    where = f"leaderboard entry {entry.name}"
    problem = manifest_mismatch(entry.protocol, root, entry.split, where) if root else None
    if problem is not None:
        raise InvalidArgument(problem)
    if entry.protocol.scorer not in KNOWN_SCORERS:
        msg = (f"{where}: its protocol's scorer is {entry.protocol.scorer!r}, which this "
               f"nsrmp-bench does not know ({list(KNOWN_SCORERS)}); state the scorer its "
               "predictions are written for")
        raise InvalidArgument(msg)


def _nan_to_none(value: object) -> object:
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, list | tuple):
        return [_nan_to_none(v) for v in value]
    if isinstance(value, dict):
        return {k: _nan_to_none(v) for k, v in value.items()}
    return value
