"""The dense baseline's configuration: sizes, image scale, optimisation and where its
validation part lies; one frozen dataclass per registered id (``dense-v1``, ``dense5x-v1``)."""

from __future__ import annotations

from dataclasses import dataclass

from nsrmp_bench.reference_model.contract import ModelConfig

__all__ = ["Dense5xConfig", "DenseConfig"]


@dataclass(frozen=True)
class DenseConfig(ModelConfig):
    """Everything that shapes a dense run; stored in every checkpoint."""

    scale: int = 4  # the image is average-pooled by this factor before the network
    width: int = 24  # channels of the full-resolution layers (doubled below)
    word_dim: int = 48
    text_hidden: int = 48
    epochs: int = 6
    batch_size: int = 32
    lr: float = 2e-3
    pick_sigma: float = 1.0  # the place stream's pick channel: a Gaussian of this many cells
    val: str = "val"  # the validation part, relative to --data
    val_limit: int = 500  # validate on at most this many single-step val episodes
    threads: int = 2
    read_workers: int = 2  # processes that read and pool the training part's images



@dataclass(frozen=True)
class Dense5xConfig(DenseConfig):
    """``dense5x-v1``: the same network on 5x the data (dense5x-v2/train), about the same
    number of gradient steps (one pass over 10,000 against six over 2,000), selected on
    paper-v2/val beside it under the same data root."""

    epochs: int = 1
    val: str = "../paper-v2/val"
