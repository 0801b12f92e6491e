"""The predictions file's formats, told by the file's name.

* JSON Lines: ``.jsonl`` (``.json`` and ``.ndjson`` are read and written as the same);
* gzip-compressed JSON Lines: ``.jsonl.gz``, the same text in a gzip stream (about a
  third of the size; the committed predictions under ``leaderboards/predictions/`` are
  stored so). Written with a fixed header (no file name, modification time 0), so the same
  predictions make the same bytes with the same zlib;
* Parquet: ``.parquet`` (one row per instance, the header in the schema metadata).

Reading is lenient (any name that is neither Parquet nor gzip is read as JSON Lines);
writing takes only these suffixes, so a typo never writes a file the reader misreads.
"""

from __future__ import annotations

import enum
import gzip
import zlib
from pathlib import Path

from nsrmp_bench.errors import InvalidArgument, SubmissionError
from nsrmp_bench.storage.atomic import atomic_write_bytes

__all__ = ["GZIP_LEVEL", "PredictionsFormat", "compress_jsonl", "decompress_jsonl",
           "first_line", "predictions_format", "read_jsonl_bytes", "write_jsonl_bytes",
           "written_format"]

GZIP_LEVEL = 9
"""zlib's compression level of a written ``.jsonl.gz`` file."""

SUFFIXES = "a .jsonl (JSON Lines), .jsonl.gz (gzip-compressed JSON Lines) or .parquet suffix"


class PredictionsFormat(enum.Enum):
    """How a predictions file's bytes hold its lines."""

    JSONL = "jsonl"
    JSONL_GZ = "jsonl.gz"
    PARQUET = "parquet"


def predictions_format(path: str | Path) -> PredictionsFormat:
    """The format a predictions file is read as: by its name's last suffix."""
    suffix = Path(path).suffix.lower()
    if suffix == ".parquet":
        return PredictionsFormat.PARQUET
    if suffix == ".gz":
        return PredictionsFormat.JSONL_GZ
    return PredictionsFormat.JSONL


def written_format(path: str | Path) -> PredictionsFormat:
    """The format a predictions file is written in; an unknown suffix is an
    :class:`InvalidArgument` naming the ones known."""
    suffixes = [s.lower() for s in Path(path).suffixes]
    if suffixes[-1:] == [".parquet"]:
        return PredictionsFormat.PARQUET
    if suffixes[-1:] in ([".jsonl"], [".json"], [".ndjson"]):
        return PredictionsFormat.JSONL
    if suffixes[-2:] in ([".jsonl", ".gz"], [".ndjson", ".gz"]):
        return PredictionsFormat.JSONL_GZ
    msg = f"predictions file {str(path)!r}: use {SUFFIXES}"
    raise InvalidArgument(msg)


def compress_jsonl(text: bytes) -> bytes:
    """The gzip stream of JSON Lines ``text`` (fixed header: the same input, the same
    bytes)."""
    return gzip.compress(text, compresslevel=GZIP_LEVEL, mtime=0)


def decompress_jsonl(path: str | Path, data: bytes) -> bytes:
    """The JSON Lines text of a ``.jsonl.gz`` file's ``data``; a file that is no complete
    gzip stream is a :class:`SubmissionError` naming the file and the fix."""
    try:
        return gzip.decompress(data)
    except (OSError, EOFError, zlib.error) as exc:
        msg = (f"predictions file {str(path)!r} is named .gz but is not a complete gzip "
               f"stream ({exc}); compress it with `gzip -k FILE.jsonl`, or pass the "
               "uncompressed .jsonl")
        raise SubmissionError(msg) from exc


def read_jsonl_bytes(path: str | Path) -> bytes:
    """The JSON Lines text of a ``.jsonl`` or ``.jsonl.gz`` file, as bytes."""
    data = Path(path).read_bytes()
    if predictions_format(path) is PredictionsFormat.JSONL_GZ:
        return decompress_jsonl(path, data)
    return data


def first_line(path: str | Path) -> bytes:
    """The first line of a ``.jsonl`` or ``.jsonl.gz`` file (its header), without reading
    the rest."""
    p = Path(path)
    try:
        if predictions_format(p) is PredictionsFormat.JSONL_GZ:
            with gzip.open(p, "rb") as fh:
                return fh.readline().rstrip(b"\r\n")
        with p.open("rb") as fh:
            return fh.readline().rstrip(b"\r\n")
    except (OSError, EOFError, zlib.error) as exc:
        msg = (f"predictions file {str(p)!r} cannot be read ({exc}); pass a .jsonl, .jsonl.gz "
               "or .parquet predictions file")
        raise SubmissionError(msg) from exc


def write_jsonl_bytes(path: str | Path, text: bytes) -> Path:
    """Write JSON Lines ``text`` atomically, gzip-compressed where ``path`` ends in
    ``.jsonl.gz``."""
    fmt = written_format(path)
    if fmt is PredictionsFormat.PARQUET:
        msg = f"predictions file {str(path)!r}: JSON Lines text is written to .jsonl or .jsonl.gz"
        raise InvalidArgument(msg)
    return atomic_write_bytes(path, compress_jsonl(text) if fmt is PredictionsFormat.JSONL_GZ
                              else text)
