"""The learned-model contract, once for every registered model (and a toy defined here):
a tiny run learns and writes the run's files, the same seed gives the same bytes, a resume
with another config is refused before anything is written, the shipped checkpoint loads
and runs, and no model (predictions, detector, reconstruction) reads ``targets``.

Every run is a few seconds: smoke-v2/test (16 episodes) serves as train and val, and each
model's ``tiny_overrides`` shrink it. The toy model (``toy_model/``) is registered below
exactly as a new model would be: its folder and one ``register`` call.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from nsrmp_bench.cli.main import main  # noqa: E402
from nsrmp_bench.errors import InvalidArgument  # noqa: E402
from nsrmp_bench.reference_model.base import PredictionModel  # noqa: E402
from nsrmp_bench.reference_model.contract import Kind  # noqa: E402
from nsrmp_bench.reference_model.registry import (  # noqa: E402
    MODELS,
    ModelEntry,
    get_model,
    register,
)
from nsrmp_bench.results.model_cards import read_training_card  # noqa: E402

pytestmark = [pytest.mark.torch, pytest.mark.sim]

TOY = register(ModelEntry("toy-v1", Kind.DENSE, "a toy that shows the contract (tests only)",
                          "toy_model:ToyModel"))
IDS = sorted(MODELS)
CHECKPOINTS = Path(__file__).resolve().parents[2] / "reference_model" / "checkpoints"
# a shipped checkpoint is optional (CONTRACT.md): the models that ship one are checked
SHIPPED = sorted(i for i in IDS if (CHECKPOINTS / f"{i}.pt").is_file())


@pytest.fixture(scope="module")
def root(smoke_test: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A split root whose train and val parts are smoke-v2/test."""
    out = tmp_path_factory.mktemp("contract-root")
    for part in ("train", "val"):
        (out / part).symlink_to(smoke_test, target_is_directory=True)
    return out


def _sets(model_id: str) -> list[str]:
    cls = get_model(model_id).model_cls()
    return [x for k, v in cls.tiny_overrides.items() for x in ("--set", f"{k}={v}")]


def _train(model_id: str, root: Path, out: Path, *extra: str) -> int:
    return main(["train", model_id, "--data", str(root), "--out", str(out), "--quiet",
                 *_sets(model_id), *extra])


@pytest.fixture(scope="module")
def runs(root: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """One tiny run per model, trained on first use."""
    return {}


def _run(runs: dict[str, Path], model_id: str, root: Path,
         tmp_path_factory: pytest.TempPathFactory) -> Path:
    if model_id not in runs:
        out = tmp_path_factory.mktemp(f"run-{model_id}")
        assert _train(model_id, root, out) == 0
        runs[model_id] = out
    return runs[model_id]


@pytest.mark.parametrize("model_id", IDS)
def test_registered_class_keeps_the_contract(model_id: str) -> None:
    entry = get_model(model_id)
    cls = entry.model_cls()  # checks its id and kind against the entry
    cfg = cls.config_cls()
    assert cfg.to_dict() == type(cfg).from_dict(cfg.to_dict()).to_dict()
    assert cls.supervision and cls.inputs
    with pytest.raises(InvalidArgument, match="threads"):
        cls.config_cls(threads=0)  # type: ignore[call-arg]


@pytest.mark.parametrize("model_id", IDS)
def test_tiny_run_learns_and_writes_the_run(model_id: str, root: Path, runs: dict[str, Path],
                                            tmp_path_factory: pytest.TempPathFactory) -> None:
    out = _run(runs, model_id, root, tmp_path_factory)
    for name in ("best.pt", "last.pt", "config.json", "log.jsonl", "card.json"):
        assert (out / name).is_file(), name
    log = [json.loads(x) for x in (out / "log.jsonl").read_text().splitlines()]
    first = [r for r in log if r["stage"] == log[0]["stage"]]
    assert len(first) >= 2 and first[-1]["loss"] < first[0]["loss"], first
    card = read_training_card(out / "card.json")
    assert card.model == model_id and card.parameters > 0 and card.config
    assert json.loads((out / "config.json").read_text()) == card.config
    cls = get_model(model_id).model_cls()
    loaded = cls.from_checkpoint(out / "best.pt").config.to_dict()
    assert json.loads(json.dumps(loaded)) == card.config  # tuples are JSON lists in the card


@pytest.mark.slow
@pytest.mark.parametrize("model_id", IDS)
def test_same_seed_same_bytes(model_id: str, root: Path, runs: dict[str, Path],
                              tmp_path_factory: pytest.TempPathFactory, tmp_path: Path) -> None:
    first = _run(runs, model_id, root, tmp_path_factory)
    assert _train(model_id, root, tmp_path / "again") == 0
    assert (tmp_path / "again" / "best.pt").read_bytes() == (first / "best.pt").read_bytes()


@pytest.mark.parametrize("model_id", IDS)
def test_resume_with_another_config_is_refused_before_writing(
        model_id: str, root: Path, runs: dict[str, Path],
        tmp_path_factory: pytest.TempPathFactory, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    import shutil

    run = tmp_path / "run"
    shutil.copytree(_run(runs, model_id, root, tmp_path_factory), run)
    before = {p.name: p.read_bytes() for p in run.iterdir()}
    assert _train(model_id, root, run, "--set", "threads=3") != 0
    err = capsys.readouterr().err
    assert "threads" in err and "--out" in err and "--restart" in err, err
    assert {p.name: p.read_bytes() for p in run.iterdir()} == before


@pytest.mark.parametrize("model_id", SHIPPED)
def test_shipped_checkpoint_loads_and_runs(model_id: str, smoke_test: Path,
                                           tmp_path: Path) -> None:
    from nsrmp_bench.reference_model import load_model

    entry = get_model(model_id)
    model = load_model(model_id)
    assert model.model_id == model_id and model.kind is entry.kind
    if entry.kind.writes_predictions:
        out = tmp_path / "p.jsonl"
        assert main(["predict", model_id, "--data", str(smoke_test), "--out", str(out),
                     "--quiet"]) == 0
        assert main(["check-submission", str(out), "--split", "smoke-v2/test", "--data",
                     str(smoke_test)]) == 0
    elif entry.kind is Kind.DETECTOR:
        out = tmp_path / "d.jsonl"
        assert main(["detect", "--detector", "learned", "--data", str(smoke_test), "--out",
                     str(out), "--quiet"]) == 0
        assert len(out.read_text().splitlines()) == 17  # a header and 16 scenes
    else:
        from nsrmp_bench.storage import open as open_storage

        with open_storage(smoke_test) as col:
            ep = col.episode(0, images=True)
        r = ep.rendering
        assert r is not None and r.observations is not None
        images = model.chain(r.observations.rgb[0],  # type: ignore[attr-defined]
                             r.targets.boxes_amodal[0], r.targets.boxes_amodal[1:])
        assert len(images) == len(r.targets.boxes_amodal) - 1
        assert images[0].shape == r.observations.rgb[0].shape


@pytest.mark.parametrize("model_id", IDS)
def test_targets_cannot_be_read(model_id: str, root: Path, runs: dict[str, Path],
                                tmp_path_factory: pytest.TempPathFactory, smoke_test: Path,
                                hide_targets: Callable[[dict[str, Any]], dict[str, Any]]) -> None:
    """Every kind runs on ``EpisodeDataset`` items whose ``targets`` fail the test when read:
    predictions, detections and reconstructions come from ``inputs`` alone."""
    from nsrmp_bench.dataset import EpisodeDataset

    ds = EpisodeDataset(smoke_test, transform=hide_targets)
    items = [ds[i] for i in range(len(ds))]
    cls = get_model(model_id).model_cls()
    model = cls.from_checkpoint(_run(runs, model_id, root, tmp_path_factory) / "best.pt")
    ids = [it["id"] for it in items]
    if isinstance(model, PredictionModel):
        assert [p.id for p in model.predict(items)] == ids
    elif model.kind is Kind.DETECTOR:
        assert [d.id for d in model.detect(items)] == ids  # type: ignore[attr-defined]
    else:
        assert model.kind is Kind.RECONSTRUCTION
        boxes = items[0]["inputs"]["boxes"].numpy()
        steps = np.stack([boxes, boxes + np.array([8.0, 0.0, 8.0, 0.0], np.float32)])
        images = model.reconstruct(items[0], steps)  # type: ignore[attr-defined]
        assert len(images) == 2 and images[0].shape == items[0]["inputs"]["rgb"].shape


def test_the_item_carries_the_camera(smoke_test: Path) -> None:
    """The camera is an input of every item, typed, and the one stored with the episode."""
    from nsrmp_bench.dataset import EpisodeDataset, collate_episodes, item_camera, shared_camera
    from nsrmp_bench.geometry.camera import Camera

    ds = EpisodeDataset(smoke_test, images=False)
    items = [ds[i] for i in range(len(ds))]
    stored = ds.collection.episode(3, images=False).rendering
    assert stored is not None
    assert isinstance(items[3]["inputs"]["camera"], Camera)
    assert item_camera(items[3]) == stored.camera == shared_camera(items)
    assert collate_episodes(items[:2])["inputs"]["camera"] == [stored.camera] * 2


def test_an_item_without_a_camera_is_refused_by_name(smoke_test: Path) -> None:
    from nsrmp_bench.dataset import EpisodeDataset, item_camera, shared_camera
    from nsrmp_bench.geometry.camera import Camera

    item = EpisodeDataset(smoke_test, images=False)[0]
    bare = {**item, "inputs": {**item["inputs"], "camera": None}}
    with pytest.raises(InvalidArgument, match=f"{item['id']}.*no camera.*with rendering"):
        item_camera(bare)
    other = {**item, "id": "other", "inputs": {**item["inputs"], "camera": Camera(
        32, 24, 40.0, (0.0, -1.0, 1.0), (0.0, 0.0, 0.0))}}
    with pytest.raises(InvalidArgument, match="'other' has another camera"):
        shared_camera([item, other])
    with pytest.raises(InvalidArgument, match="no items"):
        shared_camera([])


def test_a_kind_without_predictions_is_refused_by_predict(smoke_test: Path, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    assert main(["predict", "detector", "--data", str(smoke_test), "--out",
                 str(tmp_path / "p.jsonl")]) != 0
    assert "nsrmp-bench detect" in capsys.readouterr().err
