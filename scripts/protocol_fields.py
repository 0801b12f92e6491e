"""Write the protocol fields into every leaderboard entry (``leaderboards/entries/*.json``)
and into the header of its predictions file.

Usage::

    python scripts/protocol_fields.py            # rewrite the entries and headers
    python scripts/protocol_fields.py --check    # exit 1 where one differs

Each entry's ``"protocol"`` is recomputed from facts only: the shipped checkpoints' table
(``reference_model/protocols.json``; a ``MODEL+DETECTOR`` entry joins the detector's), the
baselines' registry (the random baseline's seed from its predictions header), the scorer
the predictions header names, and the root hash of the committed manifest of the entry's
split part. Only a predictions file's first line (its header) is rewritten (inside the
gzip stream of a ``.jsonl.gz`` file), with ``"protocol"`` added last; every prediction line
keeps its bytes, so every board's figures stay the same. Rebuild the site's copies after a
change (``nsrmp-bench leaderboard --site-only``).
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from nsrmp_bench.baselines.registry import BASELINES
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.reference_model.protocols import shipped_protocol
from nsrmp_bench.scoring.file_formats import read_jsonl_bytes, write_jsonl_bytes
from nsrmp_bench.scoring.protocol_fields import ProtocolFields
from nsrmp_bench.scoring.reader import read_header
from nsrmp_bench.scoring.version import KNOWN_SCORERS

ENTRIES = Path(__file__).resolve().parents[1] / "leaderboards" / "entries"


def _header(predictions: Path) -> dict[str, Any]:
    return dict(read_header(predictions))


def protocol_of(entry_file: Path) -> ProtocolFields:
    """The protocol of one entry, from facts (see the module doc)."""
    entry = json.loads(entry_file.read_text("utf-8"))
    split_id, _, part = str(entry["split"]).partition("/")
    committed = official_manifest(split_id, part)
    if committed is None:
        msg = f"{entry_file}: no committed manifest for {entry['split']}; it has no root hash"
        raise InvalidArgument(msg)
    root = str(committed["root_hash"])
    header = _header((entry_file.parent / entry["predictions"]).resolve())
    model, _, detector = str(entry["model"]).partition("+")
    if model in BASELINES:
        fields = BASELINES[model].protocol(int(header.get("seed", 0)), root)
    else:
        fields = shipped_protocol(model, root, detector=detector or None)
    if header["scorer"] not in KNOWN_SCORERS:
        msg = (f"{entry_file}: its predictions are for {header['scorer']!r}, which this "
               f"nsrmp-bench does not know ({list(KNOWN_SCORERS)})")
        raise InvalidArgument(msg)
    # a file that abstains somewhere is written for scorer-v2; the header says which
    return replace(fields, scorer=str(header["scorer"]))


def _header_line(predictions: Path, protocol: dict[str, Any]) -> tuple[bytes, bytes]:
    """The file's first line as it is and as it should be (the header with ``protocol``)."""
    first = read_jsonl_bytes(predictions).split(b"\n", 1)[0]
    header = json.loads(first)
    header["header"]["protocol"] = protocol
    return first, json.dumps(header, allow_nan=False).encode("utf-8")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only report differences")
    args = parser.parse_args(argv)
    differ = 0
    for path in sorted(ENTRIES.glob("*.json")):
        data = json.loads(path.read_text("utf-8"))
        want = protocol_of(path).to_dict()
        predictions = (path.parent / data["predictions"]).resolve()
        first, line = _header_line(predictions, want)
        if data.get("protocol") == want and first == line:
            continue
        differ += 1
        if args.check:
            print(f"{path.name}: protocol (entry or predictions header) differs from the "
                  "recomputed one")
            continue
        data["protocol"] = want
        path.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n", "utf-8")
        rest = read_jsonl_bytes(predictions)[len(first):]
        write_jsonl_bytes(predictions, line + rest)
    print(f"{differ} entr{'y' if differ == 1 else 'ies'} "
          f"{'differ' if args.check else 'rewritten'}")
    return 1 if args.check and differ else 0


if __name__ == "__main__":
    sys.exit(main())
