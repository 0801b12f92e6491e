"""The scene-reconstruction network (reconstruction-v1) and the ``reconstruct`` verb."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("skimage")
pytest.importorskip("cv2")

from nsrmp_bench.errors import InvalidArgument

TINY = {"channels": 8, "patch": 32, "epochs": 25, "batch_size": 16, "lr": 3e-3,
        "train_episodes": 0, "val_episodes": 0}


@pytest.fixture(scope="module")
def smoke_root(smoke_test: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A split root whose train and val parts are the smoke split."""
    root = tmp_path_factory.mktemp("recon-root")
    for part in ("train", "val"):
        (root / part).symlink_to(smoke_test, target_is_directory=True)
    return root


@pytest.fixture(scope="module")
def oracle_file(smoke_test: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from nsrmp_bench.baselines.registry import run_baseline
    from nsrmp_bench.storage import open as open_storage

    out = tmp_path_factory.mktemp("recon-oracle") / "oracle.jsonl"
    with open_storage(smoke_test) as coll:
        run_baseline("oracle", list(coll.iter_episodes()), out, split="smoke-v2/test")
    return out


@pytest.fixture(scope="module")
def tiny_run(smoke_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from nsrmp_bench.reference_model.reconstruction import (
        ReconstructionConfig,
        train_reconstruction,
    )

    out = tmp_path_factory.mktemp("recon-run")
    return train_reconstruction(smoke_root, out, seed=0, config=ReconstructionConfig(**TINY),
                                quiet=True)


def _region_ssim(images: np.ndarray, gold: np.ndarray, inputs: np.ndarray) -> float:
    from nsrmp_bench.reference_model.reconstruction.ssim import ssim_scores

    region = (inputs[:, 9] > 0) | (inputs[:, 10] > 0)
    return float(np.mean([ssim_scores(p, g, r)[1]
                          for p, g, r in zip(images, gold, region, strict=True)]))


def test_tiny_training_learns(tiny_run: Path, smoke_test: Path) -> None:
    """On its own data the trained network beats copying the image before the step and
    beats its own starting point, the pasted composite (the untrained network's output)."""
    import torch

    from nsrmp_bench.reference_model.reconstruction import ReconstructionPredictor
    from nsrmp_bench.reference_model.reconstruction.data import part_patches

    pred = ReconstructionPredictor(tiny_run)
    patches = part_patches(smoke_test, pred.model.plate.numpy(), limit=0, patch=32,
                           margin=pred.config.margin)
    x = patches.inputs
    gold = patches.targets.permute(0, 2, 3, 1).numpy()
    with torch.no_grad():
        out = (pred.model(x) * 255).round().to(torch.uint8).permute(0, 2, 3, 1).numpy()
    before = x[:, 3:6].permute(0, 2, 3, 1).numpy()
    comp = x[:, 0:3].permute(0, 2, 3, 1).numpy()
    learned = _region_ssim(out, gold, x.numpy())
    identity = _region_ssim(before, gold, x.numpy())
    pasted = _region_ssim(comp, gold, x.numpy())
    assert learned > identity + 0.05, (learned, identity)
    assert learned > pasted + 0.02, (learned, pasted)
    card = json.loads((tiny_run.parent / "card.json").read_text())
    assert card["model"] == "reconstruction-v1" and card["parameters"] > 0


def test_same_seed_same_bytes(smoke_root: Path, tmp_path: Path) -> None:
    from nsrmp_bench.reference_model.reconstruction import (
        ReconstructionConfig,
        train_reconstruction,
    )

    cfg = ReconstructionConfig(**{**TINY, "epochs": 1})
    a = train_reconstruction(smoke_root, tmp_path / "a", seed=3, config=cfg, quiet=True)
    b = train_reconstruction(smoke_root, tmp_path / "b", seed=3, config=cfg, quiet=True)
    assert a.read_bytes() == b.read_bytes()


def test_shipped_checkpoint_reconstructs_smoke(oracle_file: Path, smoke_test: Path,
                                              tmp_path: Path) -> None:
    """The shipped checkpoint, through the verb: PNG per step, sheet, JSON, all read back."""
    import cv2

    from nsrmp_bench.cli.main import main

    out = tmp_path / "recon"
    assert main(["reconstruct", str(oracle_file), "--data", str(smoke_test), "--out",
                 str(out), "--limit", "3"]) == 0
    result = json.loads((out / "ssim.json").read_text())
    assert result["renderer"] == "network" and result["summary"]["episodes"] == 3
    steps = result["steps"]
    assert steps and all(-1 <= s["whole"] <= 1 and -1 <= s["region"] <= 1 for s in steps)
    # with oracle boxes the whole image is nearly right and the boxes better than a copy
    assert result["summary"]["whole"] > 0.9
    for s in steps:
        img = cv2.imread(str(out / "images" / s["id"] / f"step-{s['predicted_step']}.png"))
        assert img is not None and img.shape == (240, 320, 3)
    sheet = cv2.imread(str(out / "sheets" / f"{steps[0]['id']}.png"))
    assert sheet is not None and sheet.shape[1] == 640
    assert sheet.shape[0] > 240 * (1 + steps[0]["steps"])


@pytest.mark.sim
def test_sim_renderer_reproduces_gold(oracle_file: Path, smoke_test: Path,
                                      tmp_path: Path) -> None:
    """PyBullet at the oracle's positions gives back the stored renders (the reference row)."""
    from nsrmp_bench.reference_model.reconstruction.reconstruct import reconstruct_file

    result = reconstruct_file(oracle_file, smoke_test, tmp_path, renderer="sim", limit=2,
                              images=False)
    assert result["summary"]["region"] > 0.95, result["summary"]


def test_file_without_step_boxes_is_refused(oracle_file: Path, smoke_test: Path,
                                            tmp_path: Path) -> None:
    from nsrmp_bench.reference_model.reconstruction.reconstruct import reconstruct_file

    lines = oracle_file.read_text().splitlines()
    stripped = [lines[0]]
    for line in lines[1:]:
        rec = json.loads(line)
        rec.pop("step_boxes", None)
        stripped.append(json.dumps(rec))
    bad = tmp_path / "no-steps.jsonl"
    bad.write_text("\n".join(stripped) + "\n")
    with pytest.raises(InvalidArgument, match="step_boxes"):
        reconstruct_file(bad, smoke_test, tmp_path / "out")


def test_wrong_split_is_refused(oracle_file: Path, smoke_test: Path, tmp_path: Path) -> None:
    from nsrmp_bench.reference_model.reconstruction.reconstruct import reconstruct_file

    lines = oracle_file.read_text().splitlines()
    head = json.loads(lines[0])
    head["header"]["split"] = "paper-v2/test"
    bad = tmp_path / "other-split.jsonl"
    bad.write_text("\n".join([json.dumps(head), *lines[1:]]) + "\n")
    with pytest.raises(InvalidArgument, match="split"):
        reconstruct_file(bad, smoke_test, tmp_path / "out")
    with pytest.raises(InvalidArgument, match="renderer"):
        reconstruct_file(oracle_file, smoke_test, tmp_path / "out", renderer="gan")
