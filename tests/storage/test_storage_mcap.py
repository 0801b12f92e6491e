"""MCAP export, read back with the ``mcap`` package's own readers; every message decoded."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from storage_factory import make_mixed

from nsrmp_bench.cli.main import main
from nsrmp_bench.storage import write_dataset

pytest.importorskip("mcap")
pytest.importorskip("mcap_protobuf")
pytest.importorskip("foxglove_schemas_protobuf")

from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap_protobuf.decoder import DecoderFactory

from nsrmp_bench.storage.mcap_export import (
    EPISODE_SCHEMA_NAME,
    encode_png,
    export_mcap,
    load_episode_schema,
)

FOXGLOVE = {"foxglove.CompressedImage", "foxglove.RawImage", "foxglove.CameraCalibration",
            "foxglove.ImageAnnotations", "foxglove.SceneUpdate", "foxglove.FrameTransforms",
            "foxglove.JointStates"}


def _reject(constant: str) -> Any:
    raise ValueError(f"non-strict JSON constant {constant}")


class StrictJson:
    """Decoder factory for JSON channels that refuses NaN and Infinity (as JavaScript does)."""

    def decoder_for(self, encoding: str, schema: Any) -> Any:
        if encoding == "json":
            return lambda data: json.loads(data, parse_constant=_reject)
        return None


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("mcap")
    write_dataset(root / "data", make_mixed, 0, 7, shard_size=4, split="test-v1")
    out = root / "all.mcap"
    summary = export_mcap(root / "data", out)
    assert summary.episodes == 7 and summary.bytes == out.stat().st_size
    return root / "data", out


def test_every_message_decodes(exported: tuple[Path, Path]) -> None:
    _, out = exported
    with out.open("rb") as fh:
        reader = make_reader(fh, validate_crcs=True,
                             decoder_factories=[DecoderFactory(), StrictJson()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        names = {s.name for s in summary.schemas.values()}
        assert names == FOXGLOVE | {EPISODE_SCHEMA_NAME}
        assert len(summary.chunk_indexes) >= 1
        assert summary.attachment_indexes and summary.metadata_indexes  # no empty groups
        counts: dict[str, int] = {}
        records = []
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            t = message.log_time
            if channel.topic == "/episode":
                records.append(decoded)
            elif channel.topic == "/tf":
                assert {x.timestamp.ToNanoseconds() for x in decoded.transforms} == {t}
            elif channel.topic == "/scene/objects":
                assert {x.timestamp.ToNanoseconds() for x in decoded.entities} == {t}
            else:  # images, calibration and annotations line up with their log time
                assert decoded.timestamp.ToNanoseconds() == t
            if channel.topic == "/camera/rgb":
                assert decoded.format == "png" and decoded.data[:4] == b"\x89PNG"
            if channel.topic == "/camera/depth":
                assert decoded.encoding == "16UC1"
                assert len(decoded.data) == decoded.step * decoded.height
        assert sum(counts.values()) == summary.statistics.message_count
        by_topic = {summary.channels[c].topic: n
                    for c, n in summary.statistics.channel_message_counts.items()}
        assert by_topic == counts
        meta = list(reader.iter_metadata())
        assert meta[0].name == "dataset" and meta[0].metadata["episodes"] == "7"
        attachments = {a.name for a in reader.iter_attachments()}
        assert "nsrmp_bench.Episode.schema.json" in attachments
    eps = [make_mixed(i) for i in range(7)]
    assert [r["id"] for r in records] == [e.id for e in eps]
    rendered = [e for e in eps if e.rendering is not None]
    states = sum(e.symbolic.num_steps + 1 for e in rendered)
    assert counts["/camera/rgb"] == counts["/camera/depth"] == states
    assert counts["/robot/joint_states"] == sum(
        len(e.rendering.trajectory.time) for e in rendered if e.rendering.trajectory)
    assert counts["/scene/objects"] == sum(e.symbolic.num_steps + 1 for e in eps)
    # NaN boxes became null, and the records follow their JSON Schema
    assert records[0]["states"][0][0]["box_visible"] is None
    jsonschema = pytest.importorskip("jsonschema")
    for r in records:
        jsonschema.validate(r, load_episode_schema())


def test_stream_reader_pass_with_crcs(exported: tuple[Path, Path]) -> None:
    _, out = exported
    with out.open("rb") as fh:
        n = sum(1 for _ in StreamReader(fh, validate_crcs=True).records)
    assert n > 0


def test_cli_export_selected_episodes(exported: tuple[Path, Path], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    data, _ = exported
    out = tmp_path / "two.mcap"
    ids = [make_mixed(3).id, make_mixed(0).id]
    assert main(["export-mcap", str(data), "--out", str(out), "--episodes", *ids]) == 0
    assert "2 episodes" in capsys.readouterr().out
    with out.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[StrictJson()])
        got = [json.loads(m.data)["id"] for _, _, m in reader.iter_messages(topics=["/episode"])]
    assert got == ids
    assert main(["export-mcap", str(data), "--out", str(out), "--episodes", "nope"]) == 2


def test_png_encoder_round_trips() -> None:
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, size=(17, 23, 3), dtype=np.uint8)
    back = cv2.imdecode(np.frombuffer(encode_png(img), np.uint8), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(back[..., ::-1], img)
