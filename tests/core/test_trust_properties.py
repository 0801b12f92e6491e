"""Properties of the readers and validators at the trust boundary (hypothesis, a few
seconds in all):

* the bounded JSON Lines reader, plain or gzip, read in chunks of any size, accepts exactly
  the files a whole-file reference model of its bounds accepts, returns their bytes
  unchanged, and raises nothing but :class:`SubmissionError`;
* a contained path is inside its folder or refused with :class:`UnsafePath`, never anything
  else, and a registry either parses into paths inside the split's folder or is refused;
* a part's read bounds grow with its instances, and a secret's estimated entropy is
  bounded by its length times the bits of its alphabet.
"""

from __future__ import annotations

import contextlib
import gzip
import math
import tempfile
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from nsrmp_bench.errors import DownloadError, SubmissionError, UnsafePath
from nsrmp_bench.private_parts import secret_bits
from nsrmp_bench.release import read_registry
from nsrmp_bench.scoring.file_formats import read_jsonl_bounded
from nsrmp_bench.scoring.read_limits import HEADER_BYTES, ReadLimits, instance_bytes
from nsrmp_bench.storage.contained import inside

FAST = settings(max_examples=60, deadline=None)
SMALL = ReadLimits(instances=3, line_bytes=HEADER_BYTES + 40, file_bytes=HEADER_BYTES + 200,
                   numbers=100, part="a test part")
TIGHT = ReadLimits(instances=2, line_bytes=30, file_bytes=150, numbers=100, part="a test part")

line_bytes = st.one_of(
    st.sampled_from([b"", b"\r", b"{}", b" ", b"x" * 40]),
    st.binary(max_size=60).map(lambda b: b.replace(b"\n", b"")),
)
files = st.lists(line_bytes, max_size=8).flatmap(
    lambda lines: st.sampled_from([b"\n".join(lines), b"\n".join(lines) + b"\n"]))


def accepted_by_reference(data: bytes, limits: ReadLimits) -> bool:
    """The bounds, checked on the whole file at once."""
    if len(data) > limits.file_bytes:
        return False
    lines = data.split(b"\n")
    if lines and lines[-1] == b"":
        lines = lines[:-1]
    if lines and len(lines[0]) > HEADER_BYTES:
        return False
    if any(len(line) > limits.line_bytes for line in lines):
        return False
    return sum(line not in (b"", b"\r") for line in lines) <= limits.lines


@FAST
@given(data=files, chunk=st.integers(1, 70), packed=st.booleans(),
       limits=st.sampled_from([SMALL, TIGHT]))
def test_the_bounded_reader_is_the_whole_file_model_read_in_chunks(
    data: bytes, chunk: int, packed: bool, limits: ReadLimits
) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / ("p.jsonl.gz" if packed else "p.jsonl")
        path.write_bytes(gzip.compress(data, mtime=0) if packed else data)
        try:
            got = read_jsonl_bounded(path, limits, chunk=chunk)
        except SubmissionError as exc:
            assert not accepted_by_reference(data, limits), exc
            assert "a test part" in str(exc) or "header" in str(exc)
        else:
            assert accepted_by_reference(data, limits)
            assert got == data


@FAST
@given(junk=st.binary(max_size=200))
def test_a_damaged_gzip_file_is_a_submission_error(junk: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "p.jsonl.gz"
        path.write_bytes(gzip.compress(b'{"header": {}}\n', mtime=0)[:10] + junk)
        with contextlib.suppress(SubmissionError):  # anything else escapes and fails
            read_jsonl_bounded(path, SMALL, chunk=16)


names = st.one_of(
    st.text(max_size=30),
    st.lists(st.sampled_from(["a", "b.h5", "..", ".", "", "/", "\\", "C:", "\x00"]),
             max_size=6).map("/".join),
)


@FAST
@given(name=names)
def test_a_contained_path_is_inside_or_refused(name: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "root"
        root.mkdir()
        try:
            path = inside(root, name, what="name", fix="fix it")
        except UnsafePath as exc:
            assert "expected a path inside" in str(exc)
        else:
            assert path.resolve().is_relative_to(root.resolve())


@FAST
@given(path=names, sha=st.sampled_from(["a" * 64, "b" * 63]), size=st.sampled_from(["1", "x"]))
def test_a_registry_parses_into_inside_paths_or_is_refused(path: str, sha: str, size: str
                                                           ) -> None:
    try:
        entries = read_registry(f"{path} {sha} {size}\n", "registry.txt")
    except DownloadError:
        return
    for e in entries:
        assert not Path(e.path).is_absolute() and ".." not in Path(e.path).parts


@FAST
@given(sizes=st.lists(st.tuples(st.integers(1, 20), st.integers(0, 10)), min_size=1,
                      max_size=30))
def test_read_bounds_grow_with_the_part(sizes: list[tuple[int, int]]) -> None:
    whole = ReadLimits.for_instances("p", sizes)
    fewer = ReadLimits.for_instances("p", sizes[:-1])
    assert whole.instances == len(sizes) == fewer.instances + 1
    assert whole.file_bytes >= fewer.file_bytes + instance_bytes(*sizes[-1])
    assert whole.line_bytes >= max(instance_bytes(o, s) for o, s in sizes)


@FAST
@given(secret=st.text(min_size=1, max_size=80))
def test_a_secrets_entropy_is_bounded_by_its_alphabet(secret: str) -> None:
    bits = secret_bits(secret)
    assert 0.0 <= bits <= len(secret) * math.log2(max(len(set(secret)), 1)) + 1e-9
