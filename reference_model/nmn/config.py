"""The NMN+ configuration: sizes, curriculum and optimisation, one frozen dataclass."""

from __future__ import annotations

from dataclasses import dataclass

from nsrmp_bench.reference_model.contract import ModelConfig
from nsrmp_bench.reference_model.nsrm.config import NSRMConfig

__all__ = ["NMNConfig"]


@dataclass(frozen=True)
class NMNConfig(ModelConfig):
    """Everything that shapes an NMN+ run; stored in every checkpoint.

    ``word_dim``, ``hidden``, ``word_dropout``, ``visual_dim`` and ``action_hidden`` size the
    parts NMN+ shares with NSRM (language encoder, splitter, visual extractor, action
    simulator): their defaults are NSRM's.
    """

    word_dim: int = 64
    hidden: int = 64
    visual_dim: int = 64
    action_hidden: int = 128
    word_dropout: float = 0.05
    attention_hidden: int = 128  # the query maps and the object-scoring MLPs
    heads: int = 2  # attention heads per role, multiplied (the original's colour and shape)
    # curriculum: epochs per stage (see reference_model/nmn/curriculum.py)
    epochs_single: int = 16
    epochs_splitter: int = 2
    epochs_multistep: int = 3
    splitter_examples: int = 1000  # the splitter stage's subset of the training episodes
    batch_size: int = 32
    lr: float = 2e-3
    max_steps: int = 7  # recursive splitting stops here
    threads: int = 2

    def shared(self) -> NSRMConfig:
        """The NSRM configuration that builds the parts NMN+ shares with NSRM."""
        return NSRMConfig(word_dim=self.word_dim, hidden=self.hidden,
                          visual_dim=self.visual_dim, action_hidden=self.action_hidden,
                          word_dropout=self.word_dropout, max_steps=self.max_steps,
                          threads=self.threads)

