"""dense-v2 and dense5x-v2 (not CLIPort): the transport's pieces do what they say, a tiny
real training run learns to pick and to place on its own data, the shipped checkpoints
predict valid files without reading targets (the pick an object's centre, that object
alone moved to the place), and bad input is a clear error (the contract tests in
``test_contract.py`` add same seed same bytes and resume for every registered model)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from nsrmp_bench.cli.main import main

torch = pytest.importorskip("torch")

pytestmark = [pytest.mark.torch, pytest.mark.sim]

TINY = ["--set", "epochs=40", "--set", "decay_epochs=5", "--set", "batch_size=4",
        "--set", "width=16", "--set", "lr=0.004", "--set", "val_limit=64", "--set", "key_dim=8",
        "--set", "crop=7"]


def _summary(pred: Path, data: Path, tmp: Path) -> dict[str, Any]:
    out = tmp / (pred.stem + ".scores.json")
    assert main(["score", str(pred), "--data", str(data), "--json", str(out), "--quiet",
                 "--n-boot", "0"]) == 0
    return json.loads(out.read_text())["summary"]  # type: ignore[no-any-return]


def test_crop_is_centred_on_the_pick_cell() -> None:
    from nsrmp_bench.reference_model.dense.transport import crop_around

    x = torch.arange(60 * 80, dtype=torch.float32).reshape(1, 1, 60, 80).repeat(3, 1, 1, 1)
    cells = torch.tensor([0, 15 * 40 + 20, 30 * 40 - 1])  # corner, middle, last cell
    win = crop_around(x, cells, 9)
    assert win.shape == (3, 1, 18, 18)
    # the centre kernel cell (4) covers pooled pixels 8..9 of the window: the pick cell's
    assert win[1, 0, 8:10, 8:10].tolist() == x[1, 0, 30:32, 40:42].tolist()
    assert win[0, 0, 8, 8] == 0 and (win[0, 0, :8] == 0).all()  # outside the image: zeros
    assert win[2, 0, 9, 9] == x[2, 0, 59, 79] and (win[2, 0, 10:] == 0).all()


def test_rotations_are_quarter_turns_for_k4() -> None:
    from nsrmp_bench.reference_model.dense.transport import rotate

    x = torch.arange(2 * 16, dtype=torch.float32).reshape(2, 1, 4, 4)
    r = rotate(x, 4)
    assert r.shape == (8, 1, 4, 4)
    assert torch.equal(rotate(x, 1), x)
    assert torch.allclose(r[0], x[0], atol=1e-4)
    assert torch.allclose(r[4 + 2], torch.rot90(x[1], 2, dims=(1, 2)), atol=1e-4)
    turned = {k: torch.rot90(x[0], k, dims=(1, 2)) for k in (1, 3)}
    assert any(torch.allclose(r[1], t, atol=1e-4) for t in turned.values())


def test_transport_peaks_where_the_scene_matches_the_crop() -> None:
    """Cross-correlation, not a learnt map: with identity key and query features, the
    place logits of a scene holding two copies of a pattern peak at those copies."""
    from nsrmp_bench.reference_model.dense.config import DenseV2Config
    from nsrmp_bench.reference_model.dense.transport import TransportNet

    net = TransportNet(5, DenseV2Config(key_dim=1, crop=3, width=4, threads=1))
    scene = torch.zeros(1, 6, 20, 20)
    for cy, cx in ((2, 3), (7, 6)):  # a bright 2x2 block on two heatmap cells
        scene[0, 0, 2 * cy:2 * cy + 2, 2 * cx:2 * cx + 2] = 1.0
    feats = lambda z, t: torch.nn.functional.avg_pool2d(z[:, :1], 2)  # noqa: E731
    net.key.features = feats  # type: ignore[method-assign]
    net.query.features = feats  # type: ignore[method-assign]
    logits = net.place_logits(scene, torch.zeros(1, 8), torch.tensor([2 * 10 + 3]))
    top = set(logits[0].topk(2).indices.tolist())
    assert top == {2 * 10 + 3, 7 * 10 + 6}, logits.reshape(10, 10)


def test_shift_moves_image_and_targets_together() -> None:
    from nsrmp_bench.reference_model.dense import shifted

    image = torch.zeros(2, 1, 6, 8)  # a grid of 3 x 4 cells
    image[:, 0, 2:4, 2:4] = 1.0  # cell (1, 1)
    pick, place = torch.tensor([1 * 4 + 1, 0]), torch.tensor([2 * 4 + 3, 5])
    for seed in range(20):
        torch.manual_seed(seed)
        out, p, q = shifted(image, pick, place, (3, 4), 1)
        for i in range(2):
            py, px = int(p[i]) // 4, int(p[i]) % 4
            dy, dx = py - int(pick[i]) // 4, px - int(pick[i]) % 4
            assert int(q[i]) == int(place[i]) + 4 * dy + dx  # the place moved alike
            if i == 0:  # the pick cell's pixels travel with it
                assert out[i, 0, 2 * py:2 * py + 2, 2 * px:2 * px + 2].eq(1).all()
                assert out[i].sum() == 4


@pytest.fixture(scope="module")
def tiny_run(smoke_test: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Trained on smoke-v2/test's 5 single-step episodes and selected on them too: the
    test asks whether it learns its own data (seconds), not whether it generalises."""
    root = tmp_path_factory.mktemp("dense2-data")
    (root / "train").symlink_to(smoke_test, target_is_directory=True)
    out = tmp_path_factory.mktemp("dense2-run")
    assert main(["train", "dense-v2", "--data", str(root), "--out", str(out), "--quiet",
                 "--set", "val=train", *TINY]) == 0
    return out


def test_tiny_training_learns_to_pick_and_place(tiny_run: Path, smoke_test: Path,
                                                tmp_path: Path) -> None:
    log = [json.loads(x) for x in (tiny_run / "log.jsonl").read_text().splitlines()]
    assert log[-1]["loss"] < 0.8 * log[0]["loss"], log
    pred, rand = tmp_path / "dense2.jsonl", tmp_path / "random.jsonl"
    train = smoke_test
    assert main(["predict", "dense-v2", "--data", str(train), "--out", str(pred),
                 "--checkpoint", str(tiny_run / "best.pt"), "--quiet"]) == 0
    assert main(["check-submission", str(pred), "--split", "smoke-v2/test", "--data",
                 str(train)]) == 0
    assert main(["baseline", "random", "--data", str(train), "--out", str(rand)]) == 0
    ours, floor = _summary(pred, train, tmp_path), _summary(rand, train, tmp_path)
    ident, ident0 = ours["identification"]["value"], floor["identification"]["value"]
    place, place0 = ours["placement"]["value"], floor["placement"]["value"]
    assert ours["identification"]["n"] == 5  # the single-step episodes it trained on
    assert ident > ident0 + 0.25 and ident > 1.8 * ident0, (ident, ident0)
    assert place > place0 + 0.3, (place, place0)
    card = json.loads((tiny_run / "card.json").read_text())
    assert card["model"] == "dense-v2" and card["label"] == "not CLIPort"
    assert card["config"]["crop"] == 7 and "single-step" in card["training_data"]


@pytest.mark.parametrize("model", ["dense-v2", "dense5x-v2"])
def test_shipped_checkpoint_predicts_a_valid_file(
        model: str, smoke_test: Path, tmp_path: Path,
        hide_targets: Callable[[dict[str, Any]], dict[str, Any]]) -> None:
    """A valid file, without reading targets, in which the pick is the centre of the
    picked object's initial box, that box alone moves, and its centre lands on the place
    (unless the image's edge clips it)."""
    from nsrmp_bench.dataset import EpisodeDataset
    from nsrmp_bench.reference_model import load_model

    ds = EpisodeDataset(smoke_test, transform=hide_targets)
    preds = list(load_model(model).predict([ds[i] for i in range(len(ds))]))
    assert [p.id for p in preds] == ds.collection.ids
    assert all(p.pick is not None and p.place is not None for p in preds)
    pred = tmp_path / f"{model}.jsonl"
    assert main(["predict", model, "--data", str(smoke_test), "--out", str(pred)]) == 0
    assert main(["check-submission", str(pred), "--split", "smoke-v2/test", "--data",
                 str(smoke_test)]) == 0
    header = json.loads(pred.read_text().splitlines()[0])["header"]
    assert header["model"] == model and header["split"] == "smoke-v2/test"
    assert _summary(pred, smoke_test, tmp_path)["identification"]["n"] == 5
    initial = {ds[i]["id"]: ds[i]["inputs"]["boxes"].numpy() for i in range(len(ds))}
    for line in pred.read_text().splitlines()[1:]:
        rec = json.loads(line)
        boxes, init = np.asarray(rec["boxes"]), initial[rec["id"]]
        centres = (init[:, :2] + init[:, 2:]) / 2
        picked = int(((centres - rec["pick"]) ** 2).sum(1).argmin())
        assert abs(centres[picked] - rec["pick"]).max() < 1e-3  # the pick is a box centre
        others = [k for k in range(len(init)) if k != picked]
        assert abs(boxes[others] - init[others]).max() < 1e-3  # only the picked one moves
        size = init[picked, 2:] - init[picked, :2]
        if (boxes[picked, 2:] - boxes[picked, :2] >= size - 1e-3).all():  # not clipped
            assert abs((boxes[picked, :2] + boxes[picked, 2:]) / 2 - rec["place"]).max() < 1e-3
    from importlib import resources

    card = resources.files("nsrmp_bench.reference_model").joinpath("checkpoints",
                                                                   f"{model}.card.json")
    facts = json.loads(card.read_text())
    assert facts["model"] == model and "not CLIPort" in facts["label"]
    assert facts["train_seconds"] > 0 and facts["wall_seconds"] > 0


def test_dense5x_v2_is_dense_v2_on_five_times_the_data_for_the_same_epochs() -> None:
    """The paper's 5x row: the same network and schedule, five times the episodes (so
    five times the steps); only where validation lies and how many processes read differ.
    The shipped checkpoints say the same."""
    from dataclasses import asdict
    from importlib import resources

    from nsrmp_bench.reference_model.dense.config import Dense5xV2Config, DenseV2Config

    one, five = asdict(DenseV2Config()), asdict(Dense5xV2Config())
    assert {k for k in one if one[k] != five[k]} == {"val", "read_workers"}
    assert five["val"] == "../paper-v2/val"
    ckpts = resources.files("nsrmp_bench.reference_model").joinpath("checkpoints")
    cards = {m: json.loads(ckpts.joinpath(f"{m}.card.json").read_text())
             for m in ("dense-v2", "dense5x-v2")}
    assert cards["dense5x-v2"]["config"]["epochs"] == cards["dense-v2"]["config"]["epochs"]
    assert cards["dense-v2"]["training_data"].startswith("2002 single-step episodes")
    assert cards["dense5x-v2"]["training_data"].startswith("10000 single-step episodes")


def test_after_training_dense5x_points_at_the_test_part_it_selected_beside(
        tmp_path: Path) -> None:
    """dense5x-v2/ has no test part: the command printed after training names
    paper-v2/test, beside the paper-v2/val it selected on; a split with a test part keeps
    its own."""
    from nsrmp_bench.cli.train import test_part
    from nsrmp_bench.reference_model.dense.config import Dense5xV2Config, DenseV2Config

    (tmp_path / "dense5x-v2" / "train").mkdir(parents=True)
    (tmp_path / "paper-v2" / "test").mkdir(parents=True)
    assert test_part(tmp_path / "dense5x-v2", Dense5xV2Config()) == tmp_path / "paper-v2" / "test"
    assert test_part(tmp_path / "paper-v2", DenseV2Config()) == tmp_path / "paper-v2" / "test"


def test_picked_object_and_its_moved_box() -> None:
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
    assert main(["train", "dense-v2", "--data", str(tiny_paper), "--out", str(tmp_path / "r"),
                 "--set", "scale=7", "--set", "read_workers=1"]) == 2
    assert "not divisible by twice the scale 7" in capsys.readouterr().err
