"""NMN+ v2's step model: what its attention's query reads, its config across checkpoints,
and that it shares every other part with NSRM v2 (the shipped run's card and log are
checked with nsrm-v2's in ``test_nsrm2.py``)."""

from __future__ import annotations

import pytest
import torch

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.nmn2.config import NMN2Config
from nsrmp_bench.reference_model.nmn2.model import AttentionStepModel

pytestmark = pytest.mark.torch


def _outputs(cfg: NMN2Config, tokens: torch.Tensor,
             code: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    torch.manual_seed(0)
    model = AttentionStepModel(12, cfg)
    r, n = tokens.shape[0], 3
    feats = torch.randn((r, n, cfg.concept_dim), generator=torch.Generator().manual_seed(1))
    centres = torch.rand((r, n, 3), generator=torch.Generator().manual_seed(2))
    mask = torch.ones((r, n), dtype=torch.bool)
    with torch.no_grad():
        subject, base, _ = model.step(code, tokens, feats, centres, torch.zeros((r, n)), mask)
    return subject, base


@pytest.mark.parametrize("query_words", ["embedding", "context"])
def test_query_reads_the_words_themselves(query_words: str) -> None:
    """With ``embedding`` the attended words' own embeddings reach the query, so two
    pieces with the same contextual states but other words are scored differently; with
    ``context`` (the first shipped run's) only the states count."""
    cfg = NMN2Config(query_words=query_words)
    code = torch.randn((1, 4, cfg.hidden), generator=torch.Generator().manual_seed(3))
    one = _outputs(cfg, torch.tensor([[3, 4, 5, 6]]), code)
    other = _outputs(cfg, torch.tensor([[3, 4, 7, 6]]), code)
    same = all(torch.allclose(a, b) for a, b in zip(one, other, strict=True))
    assert same == (query_words == "context")


def test_config_of_earlier_checkpoints() -> None:
    """A checkpoint's config without ``query_words`` loads as it was trained (the
    contextual states), a new run pools the embeddings, and a bad value names the field."""
    assert NMN2Config.from_dict({"concept_dim": 32}).query_words == "context"
    assert NMN2Config().query_words == "embedding"
    with pytest.raises(InvalidArgument, match="query_words"):
        NMN2Config(query_words="states")


def test_nmn_shares_nsrm_parts_but_the_step_model() -> None:
    """NMN+ v2 is NSRM v2's program network (splitter, action rule, the same perception)
    with attention in place of the concept step model."""
    from nsrmp_bench.reference_model.nmn2 import NMN2Model
    from nsrmp_bench.reference_model.nsrm2 import NSRM2Model
    from nsrmp_bench.reference_model.nsrm2.config import NSRM2Config
    from nsrmp_bench.reference_model.nsrm2.model import ConceptStepModel
    from nsrmp_bench.reference_model.program.modules import Perception, ProgramModel, Splitter

    nmn = NMN2Model.build_network(NMN2Config(members=1), 20, {})
    nsrm = NSRM2Model.build_network(NSRM2Config(members=1), 20, {})
    assert type(nmn) is type(nsrm) is ProgramModel
    assert type(nmn.splitter) is type(nsrm.splitter) is Splitter
    assert type(nmn.step.perception) is type(nsrm.step.perception) is Perception
    assert isinstance(nmn.step, AttentionStepModel) and isinstance(nsrm.step, ConceptStepModel)
    assert nmn.rule_values.shape == nsrm.rule_values.shape
