"""``pack`` writes Croissant metadata that mlcroissant validates and reads back."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

mlc = pytest.importorskip("mlcroissant")

from nsrmp_bench.canonical import sha256_file  # noqa: E402
from nsrmp_bench.episode_views import episode_boxes  # noqa: E402
from nsrmp_bench.release import pack  # noqa: E402
from nsrmp_bench.storage import open as open_storage  # noqa: E402


def test_pack_writes_croissant_that_mlcroissant_validates_and_reads(
        smoke_v2_root: Path, tmp_path: Path) -> None:
    release = tmp_path / "release"
    pack(smoke_v2_root, release)
    meta = release / "smoke-v2" / "croissant.json"
    doc = json.loads(meta.read_text())
    for f in doc["distribution"]:
        assert f["sha256"] == sha256_file(release / "smoke-v2" / f["contentUrl"])
    assert any(f["contentUrl"].endswith(".h5") for f in doc["distribution"])
    dataset = mlc.Dataset(jsonld=str(meta))  # validates; raises on an error
    assert not dataset.metadata.ctx.issues.errors
    assert not dataset.metadata.ctx.issues.warnings
    episodes = list(dataset.records("episodes"))
    objects = list(dataset.records("objects"))
    with open_storage(smoke_v2_root / "test") as c:
        eps = list(c.iter_episodes(images=False))
    assert len(episodes) == len(eps) == 16

    def text(v: object) -> str:
        return v.decode() if isinstance(v, bytes) else str(v)

    by_id = {text(r["episodes/id"]): r for r in episodes}
    assert sorted(by_id) == sorted(e.id for e in eps)
    assert sum(e.symbolic.num_objects for e in eps) == len(objects)
    for ep in eps:
        r = by_id[ep.id]
        assert text(r["episodes/instruction"]) == ep.symbolic.instruction.text
        assert int(r["episodes/num_steps"]) == ep.symbolic.num_steps
        assert text(r["episodes/shard"]).startswith("test/")
    first = eps[0]
    rows = [r for r in objects if text(r["objects/episode_id"]) == first.id]
    boxes = episode_boxes(first)
    assert len(rows) == first.symbolic.num_objects
    for r in rows:
        i = int(r["objects/index"])
        assert text(r["objects/shape"]) == first.symbolic.scene.objects[i].shape
        assert float(r["objects/final_x2"]) == pytest.approx(float(boxes[-1, i, 2]))
    # the registry (what download fetches) is unchanged: shards and manifests only
    registry = (release / "smoke-v2" / "registry.txt").read_text()
    assert "croissant" not in registry
