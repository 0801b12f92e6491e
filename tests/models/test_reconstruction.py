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
        "train_episodes": 0, "val_episodes": 0, "plate_episodes": 16, "head_init_std": 2.0}


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


def _train(root: Path, out: Path, **changes: object) -> Path:
    from nsrmp_bench.reference_model.reconstruction import (
        ReconstructionConfig,
        ReconstructionPredictor,
    )

    cfg = ReconstructionConfig(**{**TINY, **changes})  # type: ignore[arg-type]
    return ReconstructionPredictor.train(root, out, seed=0, config=cfg, quiet=True)


def _region_ssim(images: np.ndarray, gold: np.ndarray, inputs: np.ndarray) -> float:
    from nsrmp_bench.reference_model.reconstruction.ssim import ssim_scores

    region = (inputs[:, 9] > 0) | (inputs[:, 10] > 0)
    return float(np.mean([ssim_scores(p, g, r)[1]
                          for p, g, r in zip(images, gold, region, strict=True)]))


def _outputs(checkpoint: Path, smoke: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    import torch

    from nsrmp_bench.reference_model.reconstruction import ReconstructionPredictor
    from nsrmp_bench.reference_model.reconstruction.data import part_patches

    pred = ReconstructionPredictor.from_checkpoint(checkpoint)
    patches = part_patches(smoke, pred.model.plate.numpy(), limit=0, patch=32,
                           margin=pred.config.margin)
    with torch.no_grad():
        out = (pred.model(patches.inputs) * 255).round().to(torch.uint8)
    return (out.permute(0, 2, 3, 1).numpy(), patches.targets.permute(0, 2, 3, 1).numpy(),
            patches.inputs.numpy())


@pytest.mark.slow
def test_tiny_training_learns(smoke_root: Path, smoke_test: Path, tmp_path: Path) -> None:
    """Started from a noisy head (untrained, its output is the composite plus noise), the
    trained network beats its untrained self and copying the image before the step, in
    SSIM inside the moved boxes of its own data."""
    untrained = _train(smoke_root, tmp_path / "untrained", epochs=0)
    trained = _train(smoke_root, tmp_path / "trained")
    out, gold, x = _outputs(trained, smoke_test)
    noisy, _, _ = _outputs(untrained, smoke_test)
    learned = _region_ssim(out, gold, x)
    before = _region_ssim(x[:, 3:6].transpose(0, 2, 3, 1), gold, x)
    start = _region_ssim(noisy, gold, x)
    assert learned > before + 0.05, (learned, before)
    assert learned > start + 0.05, (learned, start)
    card = json.loads((trained.parent / "card.json").read_text())
    assert card["model"] == "reconstruction-v1" and card["parameters"] > 0
    log = [json.loads(line) for line in (trained.parent / "log.jsonl").read_text().splitlines()]
    assert len(log) == TINY["epochs"] and "val_region_ssim" in log[0]


@pytest.mark.slow
def test_same_seed_same_bytes(smoke_root: Path, tmp_path: Path) -> None:
    from nsrmp_bench.reference_model.reconstruction import (
        ReconstructionConfig,
        ReconstructionPredictor,
    )

    cfg = ReconstructionConfig(**{**TINY, "epochs": 2})  # type: ignore[arg-type]
    a = ReconstructionPredictor.train(smoke_root, tmp_path / "a", seed=3, config=cfg, quiet=True)
    b = ReconstructionPredictor.train(smoke_root, tmp_path / "b", seed=3, config=cfg, quiet=True)
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
    from nsrmp_bench.generators.world.sim_renderer import SimRenderer
    from nsrmp_bench.reference_model.reconstruction.reconstruct import reconstruct_file

    result = reconstruct_file(oracle_file, smoke_test, tmp_path, renderer="sim", limit=2,
                              images=False, sim_renderer=SimRenderer)
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
