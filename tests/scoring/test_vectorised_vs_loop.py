"""The vectorised metrics agree with an independent per-instance Python implementation."""

from __future__ import annotations

import numpy as np
import pytest
from scoring_factory import loop_scores, synthetic_tables

from nsrmp_bench.scoring.metrics import instance_scores


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_vectorised_matches_loop(seed: int) -> None:
    gold, pred = synthetic_tables(np.random.default_rng(seed), 400)
    frame, _ = instance_scores(gold, pred)
    expected = loop_scores(gold, pred)
    for name, values in expected.items():
        np.testing.assert_allclose(frame[name].to_numpy(), np.array(values), atol=1e-12,
                                   err_msg=name)
    assert frame["present"].sum() == pred.present.sum()
    assert 0 < frame["iou_m"].mean() < 1  # the synthetic predictions are partly right
