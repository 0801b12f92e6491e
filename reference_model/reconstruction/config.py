"""The reconstruction network's configuration: sizes, data and optimisation, one frozen
dataclass stored in every checkpoint."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

__all__ = ["ReconstructionConfig"]


@dataclass(frozen=True)
class ReconstructionConfig:
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

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ReconstructionConfig:
        """Inverse of :meth:`to_dict` (unknown keys are an error)."""
        return cls(**data)
