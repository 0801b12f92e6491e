"""The PyTorch Dataset: inputs apart from targets, collation, workers 0 and 2."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest
from storage_factory import make_episode, make_mixed

from nsrmp_bench.storage import open, write_dataset, write_shard

torch = pytest.importorskip("torch")
pytestmark = pytest.mark.torch

from nsrmp_bench.dataset import (  # noqa: E402
    EpisodeDataset,
    collate_episodes,
    data_loader,
    item_camera,
)
from nsrmp_bench.errors import InvalidArgument  # noqa: E402
from nsrmp_bench.vocabulary import ACTIONS, COLOURS, SHAPES  # noqa: E402


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ds")
    write_dataset(out, make_mixed, 0, 10, shard_size=4, split="test-v1")
    return out


def test_item_keeps_inputs_apart_from_targets(data: Path) -> None:
    ds = EpisodeDataset(data)
    assert len(ds) == 10
    item = ds[1]
    ep = make_mixed(1)
    r = ep.rendering
    assert r is not None and r.observations is not None
    assert set(item["inputs"]) == {"instruction", "rgb", "depth", "boxes", "camera"}
    assert item["inputs"]["instruction"] == ep.symbolic.instruction.text
    assert item_camera(item) == item["inputs"]["camera"] == r.camera
    assert item["inputs"]["rgb"].dtype == torch.uint8
    assert torch.equal(item["inputs"]["rgb"], torch.from_numpy(r.observations.rgb[0]))
    assert torch.equal(item["inputs"]["boxes"], torch.from_numpy(r.targets.boxes_amodal[0]))
    tg = item["targets"]
    s, n = ep.symbolic.num_steps, ep.symbolic.num_objects
    assert tuple(tg["boxes"].shape) == (s + 1, n, 4)
    assert torch.equal(tg["final_boxes"], torch.from_numpy(r.targets.boxes_amodal[-1]))
    assert tuple(tg["poses"].shape) == (s + 1, n, 7)
    assert tg["grounded"].tolist() == [[ACTIONS.index(g.action), g.subject, g.reference]
                                       for g in ep.symbolic.grounded]
    assert tg["program_text"] == ep.symbolic.program.text()
    assert tg["moved"].sum().item() == len(ep.symbolic.moved)
    objects = ep.symbolic.scene.objects
    assert tg["shapes"].tolist() == [SHAPES.index(o.shape) for o in objects]
    assert tg["colours"].tolist() == [COLOURS.index(o.colour) for o in objects]
    assert tg["rgb"] is None  # the renders after each step only when asked for


def test_iter_items_reads_a_window(data: Path) -> None:
    ds = EpisodeDataset(data, images=False)
    ids = [make_mixed(i).id for i in range(10)]
    assert [it["id"] for it in ds.iter_items()] == ids
    assert [it["id"] for it in ds.iter_items(3)] == ids[:3]
    assert [it["id"] for it in ds.iter_items(3, start=8)] == ids[8:]


def test_step_images_are_targets(data: Path) -> None:
    r = make_mixed(1).rendering
    assert r is not None and r.observations is not None
    item = EpisodeDataset(data, step_images=True)[1]
    assert torch.equal(item["targets"]["rgb"], torch.from_numpy(r.observations.rgb[1:]))
    assert torch.equal(item["inputs"]["rgb"], torch.from_numpy(r.observations.rgb[0]))


def test_an_episode_without_rendering_has_no_camera(data: Path) -> None:
    item = EpisodeDataset(data, step_images=True)[4]  # make_mixed: every 5th is symbolic
    assert item["inputs"]["camera"] is None and item["targets"]["rgb"] is None
    with pytest.raises(InvalidArgument, match=f"{item['id']!r} has no camera"):
        item_camera(item)


def test_collate_pads_objects_and_steps(tmp_path: Path) -> None:
    items = [make_episode(i, steps=steps, objects=objects)
             for i, (steps, objects) in enumerate([(1, 3), (2, 6), (1, 4)])]
    record = write_shard(tmp_path, 0, items, split="s")
    ds = EpisodeDataset(tmp_path / record.file)
    batch = collate_episodes([ds[i] for i in range(3)])
    assert batch["object_mask"].sum(1).tolist() == [3, 6, 4]
    assert batch["state_mask"].sum(1).tolist() == [2, 3, 2]
    assert batch["step_mask"].sum(1).tolist() == [1, 2, 1]
    assert tuple(batch["targets"]["boxes"].shape) == (3, 3, 6, 4)
    assert tuple(batch["inputs"]["boxes"].shape) == (3, 6, 4)
    assert tuple(batch["inputs"]["rgb"].shape) == (3, 24, 32, 3)
    assert batch["targets"]["grounded"][0, 1].tolist() == [-1, -1, -1]
    assert batch["targets"]["shapes"][0, 3:].tolist() == [-1, -1, -1]
    assert batch["inputs"]["camera"] == [ds[i]["inputs"]["camera"] for i in range(3)]
    assert batch["targets"]["boxes"][0, :, 3:].abs().sum().item() == 0.0


@pytest.mark.parametrize("workers", [0, 2])
def test_data_loader_workers(data: Path, workers: int) -> None:
    coll = open(data)
    coll[0]  # an open handle in the parent must not leak into forked workers
    ds = EpisodeDataset(coll)
    loader = data_loader(ds, batch_size=3, num_workers=workers, shuffle=False)
    ids, rendered = [], 0
    for batch in loader:
        ids.extend(batch["id"])
        rendered += int(batch["has_rendering"].sum())
    assert ids == [make_mixed(i).id for i in range(10)]
    assert rendered == sum(make_mixed(i).rendering is not None for i in range(10))


def test_dataset_pickles_without_handles(data: Path) -> None:
    ds = EpisodeDataset(data)
    ds[0]
    clone = pickle.loads(pickle.dumps(ds))
    assert clone[0]["id"] == ds[0]["id"]
