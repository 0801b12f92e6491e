"""`pack --inputs-only` on a generated smoke-v2: every stored field of every episode is a
data-dictionary row (docs/data.md) and none of them is gold (no targets, final states, programs,
seeds); every non-gold row survives; the manifest keeps the part's root hash and verifies
against the committed one; `EpisodeDataset` reads it as usual with no targets; reading or
scoring the gold is refused with a clear message."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
from test_data_dictionary import dictionary, stored

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.release import pack
from nsrmp_bench.storage.inputs_only import is_gold
from nsrmp_bench.storage.manifest import read_manifest
from nsrmp_bench.storage.reader import open as open_data
from nsrmp_bench.verify import verify

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def packed(smoke_v2_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("inputs-only")
    cmd = [sys.executable, "-m", "nsrmp_bench.cli.main", "pack", str(smoke_v2_root),
           "--out", str(out), "--inputs-only"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    return out / "smoke-v2" / "test"


def test_no_gold_field_survives_and_every_input_does(packed: Path) -> None:
    rows = dictionary()
    gold = {k for k in rows if is_gold(k)}
    assert {k for k in rows if k.startswith("targets/")} <= gold
    assert {"@num_steps", "@seed", "physics"} <= gold
    inputs = {k for k in rows if not is_gold(k)}
    shards = sorted(packed.glob("*.h5"))
    assert shards
    for shard in shards:
        with h5py.File(shard, "r") as f:
            assert f.attrs["inputs_only"]
            index = json.loads(f["index"].asstr()[()])
            assert all(set(r) <= {"id", "index", "objects"} for r in index)
            for eid in f["data"]:
                fields = set(stored(f["data"][eid]))
                assert fields <= set(rows), sorted(fields - set(rows))
                assert not fields & gold, sorted(fields & gold)
                assert fields == inputs, sorted(inputs - fields)


def test_the_manifest_keeps_the_root_hash_and_no_gold_categories(
        packed: Path, smoke_v2_test: Path) -> None:
    full, cut = read_manifest(smoke_v2_test), read_manifest(packed)
    assert cut.inputs_only and not full.inputs_only
    assert cut.root_hash == full.root_hash and cut.count == full.count
    assert all(set(e.categories) == {"objects"} for e in cut.episodes)
    data = json.loads((packed / "manifest.json").read_text())
    assert set(data["counts"]) == {"episodes", "shards", "objects"}
    report = verify(packed)
    assert report.ok and report.committed_root_hash == cut.root_hash, report.problems
    assert not (packed.parent / "croissant.json").exists()


def test_the_dataset_reads_its_inputs_as_usual(packed: Path, smoke_v2_test: Path) -> None:
    pytest.importorskip("torch")
    from nsrmp_bench.dataset import EpisodeDataset

    cut, full = EpisodeDataset(packed), EpisodeDataset(smoke_v2_test)
    assert len(cut) == len(full) == 16
    for i in (0, 7, 15):
        a, b = cut[i], full[i]
        assert a["targets"] is None and a["id"] == b["id"] and a["index"] == b["index"] == i
        assert a["inputs"]["instruction"] == b["inputs"]["instruction"]
        assert a["inputs"]["camera"] == b["inputs"]["camera"]
        for key in ("rgb", "depth", "boxes"):
            assert a["inputs"][key].equal(b["inputs"][key])


def test_reading_or_scoring_the_gold_is_refused(packed: Path) -> None:
    from nsrmp_bench.scoring.scorer import score

    with open_data(packed) as data:
        assert data.inputs_only
        with pytest.raises(InvalidArgument, match="inputs-only part"):
            data[0]
        with pytest.raises(InvalidArgument, match="inputs-only part"):
            data.read_targets(0)
    predictions = packed.parent.parent / "empty.jsonl"
    predictions.write_text(json.dumps({"header": {
        "format": "nsrmp-bench-predictions", "format_version": "1.0.0",
        "split": "smoke-v2/test", "scorer": "scorer-v1"}}) + "\n")
    with pytest.raises(InvalidArgument, match="score against the full part"):
        score(predictions, packed)


def test_packing_an_inputs_only_part_again_is_refused(packed: Path, tmp_path: Path) -> None:
    with pytest.raises(InvalidArgument, match="already an inputs-only part"):
        pack(packed, tmp_path, inputs_only=True)


@pytest.mark.torch
def test_predict_on_the_inputs_only_part_writes_the_same_file(
        packed: Path, smoke_v2_test: Path, tmp_path: Path) -> None:
    pytest.importorskip("torch")
    from nsrmp_bench.reference_model.part_prediction import predict_part

    _, on_full, _ = predict_part("nsrm", smoke_v2_test, tmp_path / "full.jsonl")
    _, on_cut, n = predict_part("nsrm", packed, tmp_path / "cut.jsonl")
    assert n == 16 and on_cut.read_bytes() == on_full.read_bytes()
