"""The NSRM configuration: sizes, curriculum and optimisation, one frozen dataclass."""

from __future__ import annotations

from dataclasses import dataclass

from nsrmp_bench.reference_model.contract import ModelConfig

__all__ = ["NSRMConfig"]


@dataclass(frozen=True)
class NSRMConfig(ModelConfig):
    """Everything that shapes an NSRM run; stored in every checkpoint."""

    word_dim: int = 64
    hidden: int = 64
    visual_dim: int = 64
    concept_dim: int = 16
    relation_hidden: int = 64
    action_hidden: int = 128
    margin: float = 0.85
    tau: float = 0.25
    # curriculum: epochs per stage (see reference_model/nsrm/curriculum.py)
    epochs_attribute: int = 8
    epochs_relational: int = 20
    epochs_reinforce: int = 5
    epochs_splitter: int = 5
    epochs_multistep: int = 3
    splitter_examples: int = 1000  # the splitter stage's subset of the training episodes
    batch_size: int = 32
    lr: float = 2e-3
    samples: int = 8  # REINFORCE samples per instruction
    entropy: float = 0.01
    word_dropout: float = 0.05
    max_steps: int = 7  # recursive splitting stops here
    threads: int = 2

