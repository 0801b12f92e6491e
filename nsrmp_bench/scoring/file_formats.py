"""The predictions file's formats, told by the file's name.

* JSON Lines: ``.jsonl`` (``.json`` and ``.ndjson`` are read and written as the same);
* gzip-compressed JSON Lines: ``.jsonl.gz``, the same text in a gzip stream (about a
  third of the size; the committed predictions under ``leaderboards/predictions/`` are
  stored so). Written with a fixed header (no file name, modification time 0), so the same
  predictions make the same bytes with the same zlib;
* Parquet: ``.parquet`` (one row per instance, the header in the schema metadata).

Reading is lenient (any name that is neither Parquet nor gzip is read as JSON Lines);
writing takes only these suffixes, so a typo never writes a file the reader misreads.

Reading is bounded (:func:`read_jsonl_bounded`, :mod:`~nsrmp_bench.scoring.read_limits`): the
text is read and decompressed 256 KiB at a time, and the file is refused the moment it
passes its part's lines, a line's bytes or the file's bytes, so a gzip bomb costs no more
than a valid file of the part.
"""

from __future__ import annotations

import enum
import gzip
import zlib
from pathlib import Path

import numpy as np

from nsrmp_bench.errors import InvalidArgument, SubmissionError
from nsrmp_bench.scoring.read_limits import HEADER_BYTES, ReadLimits
from nsrmp_bench.storage.atomic import atomic_write_bytes

__all__ = ["GZIP_LEVEL", "PredictionsFormat", "compress_jsonl", "decompress_jsonl",
           "first_line", "predictions_format", "read_jsonl_bounded", "read_jsonl_bytes",
           "write_jsonl_bytes", "written_format"]

CHUNK = 256 * 1024
"""Bytes read (decompressed) at a time by the bounded reader (a chunk of newlines costs
about 20 times its size in index arrays while it is counted)."""
_NEWLINE, _RETURN = ord("\n"), ord("\r")

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


def _too_long_header(path: Path) -> SubmissionError:
    return SubmissionError(
        f"predictions file {str(path)!r}: its first line (the header) is longer than "
        f"{HEADER_BYTES} bytes; expected one header object of at most that size: write the "
        "header alone on the first line")


def first_line(path: str | Path) -> bytes:
    """The first line of a ``.jsonl`` or ``.jsonl.gz`` file (its header), without reading
    the rest; a first line over :data:`~nsrmp_bench.scoring.read_limits.HEADER_BYTES` is a
    :class:`SubmissionError`."""
    p = Path(path)
    try:
        if predictions_format(p) is PredictionsFormat.JSONL_GZ:
            with gzip.open(p, "rb") as fh:
                line = fh.readline(HEADER_BYTES + 1)
        else:
            with p.open("rb") as fh:
                line = fh.readline(HEADER_BYTES + 1)
        if len(line) > HEADER_BYTES:
            raise _too_long_header(p)
        return line.rstrip(b"\r\n")
    except (OSError, EOFError, zlib.error) as exc:
        raise _unreadable(p, exc) from exc


def _unreadable(path: Path, exc: BaseException) -> SubmissionError:
    if predictions_format(path) is PredictionsFormat.JSONL_GZ:
        return SubmissionError(
            f"predictions file {str(path)!r} is named .gz but is not a complete gzip stream "
            f"({exc}); compress it with `gzip -k FILE.jsonl`, or pass the uncompressed .jsonl")
    return SubmissionError(
        f"predictions file {str(path)!r} cannot be read ({exc}); pass a readable .jsonl, "
        ".jsonl.gz or .parquet predictions file")


def _past(path: Path, limits: ReadLimits, what: str) -> SubmissionError:
    return SubmissionError(
        f"predictions file {str(path)!r} {what}, more than a file for "
        f"{limits.describe()} can hold; reading stopped there. Write one line per instance "
        "after the header (boxes, program, points only), or check that the file is the one "
        "made for this part")


class _Bound:
    """Counts what a chunked read has seen and refuses it the moment a bound is passed.

    A line is blank when it is empty or a lone ``\\r``; blank lines are not counted as
    lines, but their bytes are. The line not yet ended is kept as its length (and its first
    two bytes, to tell a lone ``\\r``), never as a copy."""

    def __init__(self, path: Path, limits: ReadLimits) -> None:
        self.path, self.limits = path, limits
        self.total = 0
        self.lines = 0
        self.tail = 0  # bytes of the line not yet ended
        self.tail_head = b""  # its first two bytes
        self.first = True

    def feed(self, chunk: bytes | memoryview) -> None:
        """The next ``chunk`` of the text (a view is not copied)."""
        limits = self.limits
        self.total += len(chunk)
        if self.total > limits.file_bytes:
            raise _past(self.path, limits, f"holds more than {limits.file_bytes} bytes of "
                        "text")
        text = np.frombuffer(chunk, dtype=np.uint8)
        ends = np.flatnonzero(text == _NEWLINE)  # vectorised: a megabyte of newlines is fast
        if ends.size:
            first = int(ends[0])
            n = self.tail + first
            self._line(n, n == 0 or (n == 1 and self.tail_head + bytes(chunk[:first]) == b"\r"))
            if ends.size > 1:
                lengths = np.diff(ends) - 1  # the lines after the first, whole in the chunk
                if int(lengths.max()) > limits.line_bytes:
                    raise _past(self.path, limits,
                                f"has a line longer than {limits.line_bytes} bytes")
                blank = int(np.count_nonzero(lengths == 0)) + int(np.count_nonzero(
                    (lengths == 1) & (text[ends[:-1] + 1] == _RETURN)))
                self._count(int(lengths.size) - blank)
            last = int(ends[-1])
            self.tail, self.tail_head = 0, b""
            chunk = chunk[last + 1:]
        if self.tail < 2:
            self.tail_head = (self.tail_head + bytes(chunk[:2]))[:2]
        self.tail += len(chunk)
        if self.tail > limits.line_bytes:
            raise _past(self.path, limits, f"has a line longer than {limits.line_bytes} bytes "
                        f"(line {self.lines + 1})")

    def _line(self, n: int, blank: bool) -> None:
        """One whole line of ``n`` bytes."""
        if self.first and n > HEADER_BYTES:
            raise _too_long_header(self.path)
        self.first = False
        if n > self.limits.line_bytes:
            raise _past(self.path, self.limits,
                        f"has a line longer than {self.limits.line_bytes} bytes")
        self._count(0 if blank else 1)

    def _count(self, lines: int) -> None:
        self.lines += lines
        if self.lines > self.limits.lines:
            raise _past(self.path, self.limits, f"holds more than {self.limits.lines} lines "
                        "(one per instance and the header)")

    def close(self) -> None:
        """The end of the file: the last line, when it has no newline."""
        if self.tail:
            self._line(self.tail, self.tail == 1 and self.tail_head == b"\r")


def read_jsonl_bounded(path: str | Path, limits: ReadLimits, *, chunk: int = CHUNK) -> bytes:
    """The JSON Lines text of a ``.jsonl`` or ``.jsonl.gz`` file, read (and decompressed)
    ``chunk`` bytes at a time and refused with a :class:`SubmissionError` the moment it
    passes ``limits``: memory and time stay those of a valid file of the part."""
    p = Path(path)
    bound = _Bound(p, limits)
    if predictions_format(p) is not PredictionsFormat.JSONL_GZ:  # its size is known first
        try:
            if p.stat().st_size > limits.file_bytes:  # refused before any reading
                raise _past(p, limits, f"holds more than {limits.file_bytes} bytes of text")
            data = p.read_bytes()
        except OSError as exc:
            raise _unreadable(p, exc) from exc
        view = memoryview(data)
        for start in range(0, len(data), chunk):
            bound.feed(view[start:start + chunk])
        bound.close()
        return data
    chunks: list[bytes] = []
    try:
        with p.open("rb") as raw, gzip.GzipFile(fileobj=raw, mode="rb") as fh:
            while piece := fh.read(chunk):
                bound.feed(piece)
                chunks.append(piece)
    except (OSError, EOFError, zlib.error) as exc:
        raise _unreadable(p, exc) from exc
    bound.close()
    return b"".join(chunks)


def write_jsonl_bytes(path: str | Path, text: bytes) -> Path:
    """Write JSON Lines ``text`` atomically, gzip-compressed where ``path`` ends in
    ``.jsonl.gz``."""
    fmt = written_format(path)
    if fmt is PredictionsFormat.PARQUET:
        msg = f"predictions file {str(path)!r}: JSON Lines text is written to .jsonl or .jsonl.gz"
        raise InvalidArgument(msg)
    return atomic_write_bytes(path, compress_jsonl(text) if fmt is PredictionsFormat.JSONL_GZ
                              else text)
