"""The dense baseline (not CLIPort): a tiny real training run learns to pick, same seed
gives the same bytes, the shipped checkpoints load and predict valid files, and the model
never reads targets."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from nsrmp_bench.cli.main import main

torch = pytest.importorskip("torch")

pytestmark = [pytest.mark.torch, pytest.mark.sim]

TINY = ["--set", "epochs=14", "--set", "batch_size=16", "--set", "width=16", "--set", "lr=0.004",
        "--set", "val_limit=64", "--set", "read_workers=1"]


def _score(pred: Path, data: Path, tmp: Path) -> dict[str, Any]:
    out = tmp / (pred.stem + ".scores.json")
    assert main(["score", str(pred), "--data", str(data), "--json", str(out), "--quiet",
                 "--n-boot", "0"]) == 0
    return json.loads(out.read_text())  # type: ignore[no-any-return]


def _headline(scores: dict[str, Any], name: str) -> float:
    return float(scores["summary"][name]["value"])


@pytest.fixture(scope="module")
def tiny_run(tiny_paper: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Trained on the tiny train part's single-step episodes and selected on them too:
    the test asks whether it learns its own data, not whether it generalises."""
    root = tmp_path_factory.mktemp("dense-data")
    (root / "train").symlink_to(tiny_paper / "train", target_is_directory=True)
    out = tmp_path_factory.mktemp("dense-run")
    assert main(["train", "dense-v1", "--data", str(root), "--out", str(out), "--quiet",
                 "--set", "val=train", *TINY]) == 0
    return out


@pytest.mark.slow
def test_tiny_training_learns_to_pick(tiny_run: Path, tiny_paper: Path,
                                      tmp_path: Path) -> None:
    log = [json.loads(x) for x in (tiny_run / "log.jsonl").read_text().splitlines()]
    assert log[-1]["loss"] < 0.8 * log[0]["loss"], log
    pred, rand = tmp_path / "dense.jsonl", tmp_path / "random.jsonl"
    train = tiny_paper / "train"
    assert main(["predict", "dense-v1", "--data", str(train), "--out", str(pred),
                 "--checkpoint", str(tiny_run / "best.pt"), "--quiet"]) == 0
    assert main(["check-submission", str(pred), "--split", "paper-v2/train", "--data",
                 str(train)]) == 0
    assert main(["baseline", "random", "--data", str(train), "--out", str(rand)]) == 0
    ours = _headline(_score(pred, train, tmp_path), "identification")
    floor = _headline(_score(rand, train, tmp_path), "identification")
    assert ours > floor + 0.25 and ours > 1.8 * floor, (ours, floor)
    card = json.loads((tiny_run / "card.json").read_text())
    assert card["parameters"] > 0 and card["label"] == "not CLIPort"
    assert "single-step" in card["training_data"]


@pytest.mark.slow
def test_same_seed_same_checkpoint_bytes(tiny_paper: Path, tmp_path: Path) -> None:
    runs = []
    for name in ("a", "b"):
        out = tmp_path / name
        assert main(["train", "dense-v1", "--data", str(tiny_paper), "--out", str(out), "--quiet",
                     "--set", "epochs=1", "--set", "width=8", "--set", "val_limit=8",
                     "--set", "read_workers=1"]) == 0
        runs.append((out / "best.pt").read_bytes())
    assert runs[0] == runs[1]


class _Forbidden(dict):  # type: ignore[type-arg]
    def __getitem__(self, key: object) -> Any:
        msg = f"the model read targets[{key!r}]"
        raise AssertionError(msg)

    def get(self, key: object, default: Any = None) -> Any:
        return self[key]


def test_model_never_reads_targets(smoke_test: Path) -> None:
    from nsrmp_bench.dataset import EpisodeDataset
    from nsrmp_bench.reference_model import load_model

    def hide(item: dict[str, Any]) -> dict[str, Any]:
        return {**item, "targets": _Forbidden()}

    ds = EpisodeDataset(smoke_test, transform=hide)
    items = [ds[i] for i in range(len(ds))]
    preds = list(load_model("dense-v1").predict(items))
    assert [p.id for p in preds] == ds.collection.ids
    assert all(p.pick is not None and p.place is not None for p in preds)


@pytest.mark.parametrize("model", ["dense-v1", "dense5x-v1"])
def test_shipped_checkpoint_predicts_valid_files(model: str, smoke_test: Path,
                                                 tmp_path: Path) -> None:
    pred = tmp_path / f"{model}.jsonl"
    assert main(["predict", model, "--data", str(smoke_test), "--out", str(pred)]) == 0
    assert main(["check-submission", str(pred), "--split", "smoke-v2/test", "--data",
                 str(smoke_test)]) == 0
    header = json.loads(pred.read_text().splitlines()[0])["header"]
    assert header["model"] == model and header["split"] == "smoke-v2/test"
    scores = _score(pred, smoke_test, tmp_path)
    assert scores["summary"]["identification"]["n"] == 5  # the single-step instances
    from nsrmp_bench.dataset import EpisodeDataset

    ds = EpisodeDataset(smoke_test, images=False)
    initial = {ds[i]["id"]: ds[i]["inputs"]["boxes"].numpy() for i in range(len(ds))}
    for line in pred.read_text().splitlines()[1:]:
        rec = json.loads(line)
        boxes, init = torch.tensor(rec["boxes"]).numpy(), initial[rec["id"]]
        centres = (init[:, :2] + init[:, 2:]) / 2
        picked = int(((centres - rec["pick"]) ** 2).sum(1).argmin())
        assert abs(centres[picked] - rec["pick"]).max() < 1e-3  # the pick is a box centre
        others = [k for k in range(len(init)) if k != picked]
        assert abs(boxes[others] - init[others]).max() < 1e-3  # only the picked one moves
        size = init[picked, 2:] - init[picked, :2]
        if (boxes[picked, 2:] - boxes[picked, :2] >= size - 1e-3).all():  # not clipped
            assert abs((boxes[picked, :2] + boxes[picked, 2:]) / 2 - rec["place"]).max() < 1e-3
    card = json.loads(Path(str(_shipped_card(model))).read_text())
    assert "not CLIPort" in card["label"]


def _shipped_card(model: str) -> Path:
    from importlib import resources

    ref = resources.files("nsrmp_bench.reference_model").joinpath("checkpoints",
                                                                  f"{model}.card.json")
    return Path(str(ref))


def test_picked_object_and_its_moved_box() -> None:
    import numpy as np

    from nsrmp_bench.reference_model.dense.inference import moved_boxes, picked_object

    boxes = np.array([[0.0, 0.0, 10.0, 10.0], [20.0, 20.0, 40.0, 30.0], [8.0, 8.0, 30.0, 30.0]])
    assert picked_object(np.array([5.0, 5.0]), boxes) == 0
    assert picked_object(np.array([9.0, 9.0]), boxes) == 0  # in two boxes: nearest centre
    assert picked_object(np.array([100.0, 100.0]), boxes) == 1  # in none: nearest centre
    moved = moved_boxes(boxes, 1, np.array([50.0, 60.0]), (320, 240))
    assert moved[1].tolist() == [40.0, 55.0, 60.0, 65.0]
    assert (moved[[0, 2]] == boxes[[0, 2]]).all()
    clipped = moved_boxes(boxes, 0, np.array([318.0, 1.0]), (320, 240))
    assert clipped[0].tolist() == [313.0, 0.0, 320.0, 6.0]


@pytest.mark.slow
def test_bad_input_is_a_clear_error(tiny_paper: Path, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["train", "dense5x", "--data", str(tiny_paper), "--out",
                 str(tmp_path / "r")]) == 2
    assert "is not a finished part; pass --set val=PATH" in capsys.readouterr().err
    assert main(["train", "dense-v1", "--data", str(tiny_paper), "--out", str(tmp_path / "r"),
                 "--set", "scale=7", "--set", "read_workers=1"]) == 2
    assert "not divisible by twice the scale 7" in capsys.readouterr().err
