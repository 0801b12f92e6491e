"""The dense baseline's configuration: sizes, image scale, optimisation, the transport and
where its validation part lies; one frozen dataclass per registered id (``dense-v2``,
``dense5x-v2``)."""

from __future__ import annotations

from dataclasses import dataclass

from nsrmp_bench.reference_model.contract import ModelConfig

__all__ = ["Dense5xV2Config", "DenseV2Config"]


@dataclass(frozen=True)
class DenseV2Config(ModelConfig):
    """``dense-v2``: the language-conditioned pick stream, and a Transporter transport for
    the place: the features of a crop of the input around the pick (``crop`` heatmap cells
    a side, at ``rotations`` angles) cross-correlated with the scene's key features, both
    language-conditioned. Stored in every checkpoint."""

    scale: int = 4  # the image is average-pooled by this factor before the network
    width: int = 24  # channels of the full-resolution layers (doubled below)
    word_dim: int = 48
    text_hidden: int = 48
    epochs: int = 14
    batch_size: int = 32
    lr: float = 2e-3
    # not used (the pick enters as the crop): the v1 place stream's pick channel, kept
    # because the shipped checkpoints' configs state it
    pick_sigma: float = 1.0
    val: str = "val"  # the validation part, relative to --data
    val_limit: int = 500  # validate on at most this many single-step val episodes
    threads: int = 1
    read_workers: int = 1  # processes that read and pool the training part's images
    decay_epochs: int = 4  # the last this many of ``epochs`` run at ``lr * decay``
    decay: float = 0.1
    shift: int = 0  # augmentation: translate each batch by up to this many cells each way
    key_dim: int = 16  # channels of the key and query features that are correlated
    crop: int = 9  # the query crop's side, in heatmap cells (odd)
    rotations: int = 1  # angles the crop is rotated over (the place marginalises them)

    def validate(self) -> None:
        super().validate()
        self.require(self.key_dim > 0, "key_dim", "a positive number of channels")
        self.require(self.crop > 0 and self.crop % 2 == 1, "crop", "a positive odd number")
        self.require(self.rotations > 0, "rotations", "at least 1")
        self.require(0 <= self.decay_epochs <= self.epochs, "decay_epochs",
                     "between 0 and epochs")
        self.require(0 < self.decay <= 1, "decay", "in (0, 1]")
        self.require(self.shift >= 0, "shift", "at least 0")


@dataclass(frozen=True)
class Dense5xV2Config(DenseV2Config):
    """``dense5x-v2``: ``dense-v2`` on 5x the data (dense5x-v2/train) for the same number
    of epochs, so five times the gradient steps and compute (the paper's "CLIPort (5x)"
    row), selected on paper-v2/val beside it under the same data root; one training
    thread as ``dense-v2`` (two processes read the 10,000 episodes)."""

    val: str = "../paper-v2/val"
    read_workers: int = 2
