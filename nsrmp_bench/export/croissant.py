"""Croissant metadata (JSON-LD, Croissant 1.0) for a packed release, written by ``pack``.

``pack`` writes ``<split>/croissant.json`` beside the release's parts, and two JSON Lines
tables it describes as record sets, under ``<split>/croissant/``:

* ``episodes.jsonl``: one record per episode (id, part, instruction, template, phrasing,
  step and object counts, whether it is relational, and the shard file holding it);
* ``objects.jsonl``: one record per object of every episode (episode id, index in scene
  order, shape, colour, gold initial and final amodal box, pixel xyxy).

Every file of the release (HDF5 shards, manifests, both tables) is a ``cr:FileObject``
with its sha256. Plain JSON: no optional dependency; ``mlcroissant`` validates and reads
it (tests do).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

import numpy as np

from nsrmp_bench.canonical import sha256_file
from nsrmp_bench.episode_views import episode_boxes
from nsrmp_bench.errors import InvalidArgument

if TYPE_CHECKING:
    from nsrmp_bench.storage.manifest import Manifest
    from nsrmp_bench.storage.reader import EpisodeCollection

__all__ = ["CROISSANT_CONTEXT", "CROISSANT_NAME", "write_croissant"]

CROISSANT_NAME: Final = "croissant.json"
CROISSANT_CONTEXT: Final[dict[str, Any]] = {
    "@language": "en",
    "@vocab": "https://schema.org/",
    "citeAs": "cr:citeAs",
    "column": "cr:column",
    "conformsTo": "dct:conformsTo",
    "cr": "http://mlcommons.org/croissant/",
    "rai": "http://mlcommons.org/croissant/RAI/",
    "data": {"@id": "cr:data", "@type": "@json"},
    "dataType": {"@id": "cr:dataType", "@type": "@vocab"},
    "dct": "http://purl.org/dc/terms/",
    "equivalentProperty": "cr:equivalentProperty",
    "examples": {"@id": "cr:examples", "@type": "@json"},
    "extract": "cr:extract",
    "field": "cr:field",
    "fileProperty": "cr:fileProperty",
    "fileObject": "cr:fileObject",
    "fileSet": "cr:fileSet",
    "format": "cr:format",
    "includes": "cr:includes",
    "isLiveDataset": "cr:isLiveDataset",
    "jsonPath": "cr:jsonPath",
    "key": "cr:key",
    "md5": "cr:md5",
    "parentField": "cr:parentField",
    "path": "cr:path",
    "recordSet": "cr:recordSet",
    "references": "cr:references",
    "regex": "cr:regex",
    "repeated": "cr:repeated",
    "replace": "cr:replace",
    "samplingRate": "cr:samplingRate",
    "sc": "https://schema.org/",
    "separator": "cr:separator",
    "source": "cr:source",
    "subField": "cr:subField",
    "transform": "cr:transform",
}
"""The Croissant 1.0 JSON-LD context (the specification's, verbatim)."""

_EPISODE_FIELDS: Final = (
    ("id", "sc:Text", "episode id"),
    ("part", "sc:Text", "the split part (test, train, ...)"),
    ("instruction", "sc:Text", "the natural-language instruction"),
    ("template_id", "sc:Text", "the instruction template"),
    ("phrasing", "sc:Text", "the phrasing category"),
    ("num_steps", "sc:Integer", "steps of the gold program"),
    ("num_objects", "sc:Integer", "objects on the table"),
    ("relational", "sc:Boolean", "whether a reference is relational"),
    ("shard", "sc:Text", "the HDF5 shard (part/file) holding the episode"),
)
_BOX = ("x1", "y1", "x2", "y2")
_OBJECT_FIELDS: Final = (
    ("episode_id", "sc:Text", "the episode's id"),
    ("index", "sc:Integer", "the object's index in scene order"),
    ("shape", "sc:Text", "cube, dice or lego"),
    ("colour", "sc:Text", "one of the seven colours"),
    *((f"initial_{c}", "sc:Float", f"gold initial amodal box {c} (pixels)") for c in _BOX),
    *((f"final_{c}", "sc:Float", f"gold final amodal box {c} (pixels)") for c in _BOX),
)


def _jsonl(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("w", encoding="utf-8") as fh:
        for row in rows:
            fh.write(json.dumps(row, sort_keys=True) + "\n")
    tmp.replace(path)


def _tables(split_dir: Path, parts: Sequence[str]) -> tuple[list[dict[str, Any]],
                                                             list[dict[str, Any]]]:
    from nsrmp_bench.storage import open as open_storage

    episodes: list[dict[str, Any]] = []
    objects: list[dict[str, Any]] = []
    for part in parts:
        with open_storage(split_dir / part) as collection:
            shard_of = {e.id: f"{part}/{s.file}" for s in _manifest(collection).shards
                        for e in s.episodes}
            for ep in collection.iter_episodes(images=False):
                sym = ep.symbolic
                episodes.append({
                    "id": sym.id, "part": part, "instruction": sym.instruction.text,
                    "template_id": sym.instruction.template_id,
                    "phrasing": sym.instruction.phrasing, "num_steps": sym.num_steps,
                    "num_objects": sym.num_objects, "relational": bool(sym.relational),
                    "shard": shard_of[sym.id],
                })
                boxes = np.asarray(episode_boxes(ep), dtype=np.float64)
                for i, obj in enumerate(sym.scene.objects):
                    row: dict[str, Any] = {"episode_id": sym.id, "index": i,
                                           "shape": obj.shape, "colour": obj.colour}
                    for c, name in enumerate(_BOX):
                        row[f"initial_{name}"] = float(boxes[0, i, c])
                        row[f"final_{name}"] = float(boxes[-1, i, c])
                    objects.append(row)
    return episodes, objects


def _record_set(name: str, description: str, file_id: str,
                fields: Sequence[tuple[str, str, str]]) -> dict[str, Any]:
    return {
        "@type": "cr:RecordSet",
        "@id": name,
        "name": name,
        "description": description,
        "field": [
            {"@type": "cr:Field", "@id": f"{name}/{col}", "name": col, "description": desc,
             "dataType": dtype,
             "source": {"fileObject": {"@id": file_id}, "extract": {"column": col}}}
            for col, dtype, desc in fields
        ],
    }


def write_croissant(split_dir: Path, split: str, parts: Sequence[str], *,
                    description: str = "", version: str = "0.1.0",
                    date_published: str | None = None) -> Path:
    """Write ``split_dir/croissant.json`` and its tables for the packed ``parts``
    (``date_published``: ISO date, default today in UTC)."""
    table_dir = split_dir / "croissant"
    table_dir.mkdir(exist_ok=True)
    episodes, objects = _tables(split_dir, parts)
    _jsonl(table_dir / "episodes.jsonl", episodes)
    _jsonl(table_dir / "objects.jsonl", objects)
    files: list[dict[str, Any]] = []
    for part in parts:
        for path in sorted((split_dir / part).iterdir()):
            fmt = "application/json" if path.suffix == ".json" else "application/x-hdf5"
            files.append(_file_object(split_dir, path, fmt))
    for name in ("episodes.jsonl", "objects.jsonl"):
        files.append(_file_object(split_dir, table_dir / name, "application/jsonlines"))
    doc = {
        "@context": CROISSANT_CONTEXT,
        "@type": "sc:Dataset",
        "conformsTo": "http://mlcommons.org/croissant/1.0",
        "name": f"nsrmp-bench-{split}",
        "description": description or (
            f"nsrmp-bench split {split}: language-guided tabletop manipulation episodes "
            "(instruction, grounded program, RGB-D renders per step, object poses and "
            "amodal boxes) in HDF5 shards."),
        "license": "https://opensource.org/licenses/MIT",
        "url": "https://pypi.org/project/nsrmp-bench/",
        "version": version,
        "datePublished": date_published or datetime.now(timezone.utc).date().isoformat(),
        "citeAs": ("Kalithasan et al., Learning Neuro-symbolic Programs for Language Guided "
                   "Robot Manipulation, ICRA 2023"),
        "distribution": files,
        "recordSet": [
            _record_set("episodes", "one record per episode", "episodes.jsonl",
                        _EPISODE_FIELDS),
            _record_set("objects", "one record per object of every episode",
                        "objects.jsonl", _OBJECT_FIELDS),
        ],
    }
    out = split_dir / CROISSANT_NAME
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(json.dumps(doc, indent=1) + "\n", "utf-8")
    tmp.replace(out)
    return out


def _file_object(split_dir: Path, path: Path, fmt: str) -> dict[str, Any]:
    rel = path.relative_to(split_dir).as_posix()
    return {
        "@type": "cr:FileObject",
        "@id": path.name if path.parent.name == "croissant" else rel,
        "name": rel,
        "contentUrl": rel,
        "contentSize": f"{path.stat().st_size} B",
        "encodingFormat": fmt,
        "sha256": sha256_file(path),
    }


def _manifest(collection: EpisodeCollection) -> Manifest:
    """The part's manifest (a part directory always has one)."""
    if collection.manifest is None:
        msg = f"{collection.root} is a single shard; give its part directory (with manifest.json)"
        raise InvalidArgument(msg)
    return collection.manifest
