"""Hostile predictions files against the bounded reader: peak memory and time to refuse.

Each case is ``check_submission(FILE, split="paper-v2/test")`` (what ``nsrmp-bench
check-submission`` runs; the bounds are the committed manifest's, no data needed) in its
own process; the script prints whether the file was refused, the seconds the check took
(imports excluded), the peak memory the check allocated (``tracemalloc``, numpy's arrays
included), the process's peak resident memory after its imports and at its end
(``ru_maxrss``, MiB), against the same check of a valid committed predictions file of the
part (gzip-compressed and plain). The hostile files are made in a temporary folder:

* ``gzip bomb (zeros|newlines)``: a header, then 2 MB of gzip members that decompress to
  2 GiB of ``0`` or of newlines;
* ``newlines 256 MiB``: a header, then 256 MiB of newlines (plain);
* ``many lines``: a header, then a million short lines (plain, 26 MB);
* ``parquet bomb``: one row whose ``boxes`` hold 16 million zeros (a few kB on disk).

Run from the repository's root::

    .venv/bin/python benchmarks/bench_hostile_files.py
"""

from __future__ import annotations

import argparse
import gzip
import json
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PART = "paper-v2/test"
VALID = REPO / "leaderboards" / "predictions" / "paper-v2-test--oracle-v1.jsonl.gz"
HEADER = (json.dumps({"header": {"format": "nsrmp-bench-predictions", "format_version": "1.0.0",
                                 "split": PART, "scorer": "scorer-v1"}}) + "\n").encode()


_CHILD = """
import json, resource, sys, time, tracemalloc
from nsrmp_bench.errors import NSRMPError
from nsrmp_bench.scoring.check import check_submission
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
tracemalloc.start()
start = time.perf_counter()
said = ""
try:
    check_submission(sys.argv[1], split=sys.argv[2])
except NSRMPError as exc:
    said = str(exc)
seconds = time.perf_counter() - start
traced = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"seconds": seconds, "before": before / 1024, "after": after / 1024,
                  "traced": traced / 2**20, "said": said}))
"""


def measure(path: Path) -> dict[str, object]:
    """What the check of ``path`` took, in its own process."""
    done = subprocess.run([sys.executable, "-c", _CHILD, str(path), PART], check=True,
                          capture_output=True, text=True)
    out: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    return out


def gzip_bomb(path: Path, filler: bytes) -> Path:
    member = zlib.compressobj(9, zlib.DEFLATED, 31)
    one = member.compress(filler * (16 << 20)) + member.flush()
    path.write_bytes(gzip.compress(HEADER, mtime=0) + one * 128)
    return path


def parquet_bomb(path: Path) -> Path:
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    n = 4_000_000
    flat = pa.array(np.zeros(4 * n))
    boxes = pa.ListArray.from_arrays(pa.array([0, n], pa.int32()),
                                     pa.FixedSizeListArray.from_arrays(flat, 4).cast(
                                         pa.list_(pa.float64())))
    table = pa.table({"id": ["paper-v2-test-000000"], "boxes": boxes})
    header = json.loads(HEADER)["header"]
    pq.write_table(table.replace_schema_metadata({"nsrmp_bench.header": json.dumps(header)}),
                   path, compression="zstd")
    return path


def main(argv: list[str] | None = None) -> int:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        plain = t / "valid.jsonl"
        plain.write_bytes(gzip.decompress(VALID.read_bytes()))
        many = t / "many.jsonl"
        many.write_bytes(HEADER + b'{"id":"x","boxes":[]}\n' * 1_000_000)
        newlines = t / "newlines.jsonl"
        with newlines.open("wb") as fh:
            fh.write(HEADER)
            for _ in range(256):
                fh.write(b"\n" * (1 << 20))
        cases = [
            ("valid .jsonl.gz (the oracle's)", VALID),
            ("valid .jsonl", plain),
            ("gzip bomb (zeros)", gzip_bomb(t / "zeros.jsonl.gz", b"0")),
            ("gzip bomb (newlines)", gzip_bomb(t / "newlines.jsonl.gz", b"\n")),
            ("newlines 256 MiB", newlines),
            ("many lines", many),
            ("parquet bomb", parquet_bomb(t / "bomb.parquet")),
        ]
        print(f"check_submission(FILE, split={PART!r}) (bounds of the committed manifest)")
        print(f"{'file':32} {'size MB':>8} {'refused':>7} {'check s':>7} {'MiB traced':>10} "
              f"{'MiB imported':>12} {'MiB peak':>8}  said")
        for name, path in cases:
            m = measure(path)
            said = str(m["said"]).split("; ")[0].split(" ", 3)[-1][:70]
            print(f"{name:32} {path.stat().st_size / 1e6:8.2f} {'yes' if m['said'] else 'no':>7} "
                  f"{m['seconds']:7.2f} {m['traced']:10.1f} {m['before']:12.0f} "
                  f"{m['after']:8.0f}  {said}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
