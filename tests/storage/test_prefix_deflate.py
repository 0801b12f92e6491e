"""PrefixDeflater gives exactly ``zlib.compress`` for every stream, whatever it learnt, and
skips the bytes a stream shares with the learnt background; the writers use it and write
the bytes they wrote without it."""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np
import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage import prefix_deflate
from nsrmp_bench.storage.prefix_deflate import PrefixDeflater

HEIGHT, WIDTH = 60, 80


def _background(rng: np.random.Generator) -> np.ndarray:
    """A scene without objects: a smooth wall above a noisy (textured) table."""
    img = np.empty((HEIGHT, WIDTH, 3), np.uint8)
    img[: HEIGHT // 3] = np.linspace(90, 140, WIDTH, dtype=np.uint8)[None, :, None]
    img[HEIGHT // 3:] = rng.integers(100, 130, (HEIGHT - HEIGHT // 3, WIDTH, 3))
    return img


def _with_objects(background: np.ndarray, rng: np.random.Generator, top: int) -> np.ndarray:
    """The background with two boxes drawn over it, the highest starting at row ``top``."""
    img = background.copy()
    for row in (top, int(rng.integers(top, HEIGHT - 6))):
        col = int(rng.integers(0, WIDTH - 8))
        img[row:row + 6, col:col + 8] = rng.integers(0, 256, 3)
    return img


def test_every_stream_is_zlibs_and_the_shared_rows_are_skipped() -> None:
    rng = np.random.default_rng(7)
    bg = _background(rng)
    deflater = PrefixDeflater(min_step=512)
    tops = [int(t) for t in rng.integers(HEIGHT // 3, HEIGHT - 6, 12)]
    for i, top in enumerate(tops):
        deflater.next_episode()
        for level in (1, 6):
            raw = _with_objects(bg, rng, top).tobytes()
            assert deflater.compress(raw, level, "rgb") == zlib.compress(raw, level), (i, level)
        if i < 3:  # the first three episodes vote; nothing is resumed yet
            assert deflater.resumed_bytes == 0
    # the nine later episodes, at two levels: each skipped at least the rows above its
    # highest box, but for a checkpoint's step
    row = WIDTH * 3
    least = sum(max(0, top * row - 512) for top in tops[3:]) * 2
    assert deflater.resumed_bytes >= least > 0


def test_the_background_itself_and_a_stream_that_differs_at_once() -> None:
    rng = np.random.default_rng(3)
    bg = _background(rng)
    deflater = PrefixDeflater(min_step=512)
    for col in (0, 30, 60):  # three scenes, their boxes apart: the majority is the background
        deflater.next_episode()
        img = bg.copy()
        img[HEIGHT // 2:HEIGHT // 2 + 6, col:col + 8] = (255, 0, 0)
        deflater.compress(img.tobytes(), 1, "rgb")
    same = bg.tobytes()  # all of it skipped but for the last checkpoint's step
    assert deflater.compress(same, 1, "rgb") == zlib.compress(same, 1)
    assert deflater.resumed_bytes >= len(same) - 512
    before = deflater.resumed_bytes
    other = bytes([255 - same[0]]) + same[1:]
    assert deflater.compress(other, 1, "rgb") == zlib.compress(other, 1)
    assert deflater.resumed_bytes == before


def test_kinds_lengths_and_episodes_keep_their_own_references() -> None:
    rng = np.random.default_rng(5)
    bg = _background(rng)
    deflater = PrefixDeflater(min_step=512)
    odd = bg.tobytes()[:-5]  # a length not a multiple of 8 compares byte by byte
    for episode in range(3):
        deflater.next_episode()
        for _ in range(3):  # one vote per kind and episode, however many streams
            raw = _with_objects(bg, rng, HEIGHT // 2).tobytes()
            assert deflater.compress(raw, 1, "a") == zlib.compress(raw, 1)
        if episode < 2:
            assert deflater.resumed_bytes == 0
        assert deflater.compress(odd, 1, "a") == zlib.compress(odd, 1)
    before = deflater.resumed_bytes
    assert deflater.compress(odd, 1, "a") == zlib.compress(odd, 1)  # its own reference
    assert deflater.resumed_bytes > before
    before = deflater.resumed_bytes
    raw = bg.tobytes()
    assert deflater.compress(raw, 1, "b") == zlib.compress(raw, 1)  # another kind: learning
    assert deflater.compress(raw, 9, "a") == zlib.compress(raw, 9)  # another level: too
    for _ in range(4):  # an empty stream, learnt and compressed again
        deflater.next_episode()
        assert deflater.compress(b"", 1, "a") == zlib.compress(b"", 1)
    assert deflater.resumed_bytes == before


def test_level_0_is_never_resumed() -> None:
    """Stored blocks are sized by how the input arrives: a resumed stream would differ."""
    raw = np.random.default_rng(11).integers(0, 256, 70_000, np.uint8).tobytes()
    deflater = PrefixDeflater(votes=1, min_step=512)
    for _ in range(2):
        deflater.next_episode()
        assert deflater.compress(raw, 0, "a") == zlib.compress(raw, 0)
    assert deflater.resumed_bytes == 0


def test_a_zlib_whose_output_depends_on_the_split_is_never_resumed(
    monkeypatch: pytest.MonkeyPatch
) -> None:
    """The reference's check (resumed from its middle checkpoint, against zlib's own
    output) finds such a build once; its kind is compressed whole from then on."""
    resumed = prefix_deflate._Reference.resumed
    monkeypatch.setattr(prefix_deflate._Reference, "resumed",
                        lambda self, raw, j: resumed(self, raw, j) + b"\0")
    bg = _background(np.random.default_rng(2)).tobytes()
    deflater = PrefixDeflater(votes=1, min_step=512)
    for _ in range(3):
        deflater.next_episode()
        assert deflater.compress(bg, 1, "rgb") == zlib.compress(bg, 1)
    assert deflater.resumed_bytes == 0
    monkeypatch.undo()  # the check itself resumes what a sound zlib gives
    deflater = PrefixDeflater(votes=1, min_step=512)
    for _ in range(2):
        deflater.next_episode()
        assert deflater.compress(bg, 1, "rgb") == zlib.compress(bg, 1)
    assert deflater.resumed_bytes > 0


@pytest.mark.parametrize(("kwargs", "named"), [({"votes": 2}, "votes must be an odd number"),
                                               ({"votes": 0}, "got 0"),
                                               ({"votes": 257}, "from 1 to 255 .*got 257"),
                                               ({"checkpoints": 0}, "got 0 and 8192")])
def test_bad_settings_are_refused_by_name(kwargs: dict[str, int], named: str) -> None:
    with pytest.raises(InvalidArgument, match=named):
        PrefixDeflater(**kwargs)


def test_the_writers_resume_and_write_the_bytes_they_wrote_without_it(
    smoke_v2_test: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """smoke-v2/test (16 rendered episodes) written with the resumed compression and with
    plain zlib in its place: the same file; and the writer did resume."""
    pytest.importorskip("pybullet")
    from nsrmp_bench.storage import open as open_part
    from nsrmp_bench.storage.writer import shard_writer

    with open_part(smoke_v2_test) as part:
        episodes = [part.episode(i) for i in range(len(part))]

    def write(out: Path) -> tuple[bytes, int]:
        with shard_writer(out, 0, len(episodes), split="smoke-v2/test", background=False) as w:
            for ep in episodes:
                w.add(ep)
            record = w.commit()
        return (out / record.file).read_bytes(), w._deflater.resumed_bytes

    resumed, skipped = write(tmp_path / "resumed")
    monkeypatch.setattr(PrefixDeflater, "compress",
                        lambda self, raw, level, kind: zlib.compress(raw, level))
    plain, _ = write(tmp_path / "plain")
    assert resumed == plain
    assert skipped > 1_000_000  # 13 episodes after the vote, RGB and segmentation
