"""The reconstruction network's configuration: sizes, data and optimisation, one frozen
dataclass stored in every checkpoint."""

from __future__ import annotations

from dataclasses import dataclass

from nsrmp_bench.reference_model.contract import ModelConfig

__all__ = ["ReconstructionConfig"]


@dataclass(frozen=True)
class ReconstructionConfig(ModelConfig):
    """Everything that shapes a reconstruction run; the defaults are the shipped run's."""

    channels: int = 16  # width of the first U-Net level (x2, x4 below it)
    patch: int = 40  # training patch side (pixels), one around each moved box
    margin: int = 3  # pixels the network's region extends beyond the boxes
    plate_episodes: int = 300  # initial images whose per-pixel median is the plate
    head_init_std: float = 0.0  # 0: the untrained network outputs the composite exactly
    epochs: int = 3
    batch_size: int = 32
    lr: float = 2e-3
    train_episodes: int = 1000  # the first this many training episodes (0: all)
    val_episodes: int = 150  # the first this many validation episodes
    threads: int = 2

    def validate(self) -> None:
        """The patch is a multiple of 4 (the U-Net pools twice) and at least 8."""
        super().validate()
        self.require(self.patch % 4 == 0 and self.patch >= 8, "patch",
                     "must be a multiple of 4 and at least 8")
