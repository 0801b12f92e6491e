"""The learned detector's configuration: one frozen dataclass, stored in its checkpoint."""

from __future__ import annotations

from dataclasses import dataclass

from nsrmp_bench.reference_model.contract import ModelConfig

__all__ = ["DetectorConfig"]


@dataclass(frozen=True)
class DetectorConfig(ModelConfig):
    """Everything that shapes a detector run (defaults: the shipped run)."""

    width: int = 24  # channels at stride 4; 1.5x at stride 8
    epochs: int = 6
    batch_size: int = 16
    lr: float = 3e-3
    crop_width: int = 128  # training crops (multiples of 8); prediction sees whole images
    crop_height: int = 96
    score_threshold: float = 0.3  # a peak at least this confident is a detection
    max_detections: int = 32
    train_limit: int = 1500  # use only the first N training episodes (0: all)
    val_limit: int = 200  # select on the first N validation episodes
    threads: int = 2

