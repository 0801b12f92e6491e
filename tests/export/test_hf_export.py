"""``export-hf``: Parquet written by datasets' own writer, loaded back by
``datasets.load_dataset``, every field equal to the HDF5 episode's."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

datasets = pytest.importorskip("datasets")

from nsrmp_bench.cli.main import main  # noqa: E402
from nsrmp_bench.episode import SymbolicEpisode  # noqa: E402
from nsrmp_bench.errors import InvalidArgument  # noqa: E402
from nsrmp_bench.geometry.camera import Camera  # noqa: E402
from nsrmp_bench.storage import open as open_storage  # noqa: E402


@pytest.fixture(scope="module")
def exported(smoke_v2_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("hf") / "smoke"
    assert main(["export-hf", str(smoke_v2_root), "--out", str(out), "--quiet"]) == 0
    return out


def test_load_dataset_round_trips_every_field(exported: Path, smoke_v2_root: Path,
                                              tmp_path: Path) -> None:
    loaded = datasets.load_dataset(str(exported), cache_dir=str(tmp_path / "cache"))
    assert list(loaded) == ["test"]
    ds = loaded["test"]
    with open_storage(smoke_v2_root / "test") as collection:
        assert len(ds) == len(collection) == 16
        for i, row in enumerate(ds):
            ep = collection.episode(i, images=True)
            sym, rend = ep.symbolic, ep.rendering
            assert rend is not None and rend.observations is not None
            obs, tg = rend.observations, rend.targets
            assert row["id"] == ep.id and row["split"] == "smoke-v2/test"
            assert row["instruction"] == sym.instruction.text
            assert row["template_id"] == sym.instruction.template_id
            assert row["num_steps"] == sym.num_steps
            assert SymbolicEpisode.from_dict(json.loads(row["symbolic"])) == sym
            assert Camera.from_dict(json.loads(row["camera"])) == rend.camera
            assert [(p["action"], p["subject"], p["reference"]) for p in row["program"]] == [
                (s.action, s.subject, s.reference) for s in sym.grounded]
            assert [(o["shape"], o["colour"]) for o in row["objects"]] == [
                (o.shape, o.colour) for o in sym.scene.objects]
            assert len(row["rgb"]) == obs.rgb.shape[0]
            for k, image in enumerate(row["rgb"]):
                assert np.array_equal(np.asarray(image), obs.rgb[k])
            assert np.array_equal(np.asarray(row["depth"], dtype=np.float32), obs.depth)
            assert np.array_equal(np.asarray(row["segmentation"], dtype=np.int16),
                                  obs.segmentation)
            assert np.array_equal(np.asarray(row["poses"]), tg.poses)
            for name in ("boxes_amodal", "boxes_visible", "visible_fraction", "depth_centre"):
                np.testing.assert_array_equal(np.asarray(row[name], dtype=np.float32),
                                              getattr(tg, name))
            np.testing.assert_array_equal(np.asarray(row["intrinsics"]),
                                          rend.camera.intrinsics)


def test_card_names_the_split_and_its_parts(exported: Path) -> None:
    card = (exported / "README.md").read_text()
    assert "config_name: smoke-v2" in card and "- split: test" in card
    assert "path: test/*.parquet" in card
    assert sorted(p.name for p in exported.iterdir()) == ["README.md", "test"]


def test_a_non_empty_target_is_refused_and_a_failed_export_leaves_nothing(
        smoke_v2_root: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from nsrmp_bench.export.hf import export_hf

    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "old.parquet").write_text("x")
    with pytest.raises(InvalidArgument, match=r"'.*busy' is not empty.*old.parquet"):
        export_hf(smoke_v2_root, busy)
    from nsrmp_bench.export import hf

    calls = []

    def failing(ep, split):  # type: ignore[no-untyped-def]
        calls.append(ep.id)
        if len(calls) > 2:
            raise RuntimeError("disk full")
        return original(ep, split)

    original = hf.episode_row
    monkeypatch.setattr(hf, "episode_row", failing)
    with pytest.raises(RuntimeError, match="disk full"):
        export_hf(smoke_v2_root, tmp_path / "new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["busy"]
