"""The rollout journal: durable lines, a line cut short by a kill dropped, another run's
journal refused, records that rebuild the same predictions lines."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.submission import Prediction
from nsrmp_bench.serving.journal import RolloutJournal, journal_path, prediction_from_record

RUN = {"split": "smoke-v2/test", "policy": "oracle", "instances": 3}


def _prediction(i: int) -> Prediction:
    rng = np.random.default_rng(i)
    return Prediction(id=f"x-{i:06d}", boxes=rng.random((4, 4)) * 300,
                      program=(GroundedStep("top", 0, 1),),
                      step_boxes=rng.random((1, 4, 4)) * 300, pick=(1.25, 2.5),
                      place=(3.0, 4.0), positions=rng.random((4, 3)))


def test_records_rebuild_the_same_lines() -> None:
    for i in range(5):
        record = _prediction(i).to_record()
        assert prediction_from_record(record).to_record() == record


def test_a_rerun_resumes_and_a_cut_line_is_dropped(tmp_path: Path) -> None:
    path = journal_path(tmp_path / "p.jsonl")
    journal = RolloutJournal(path, RUN)
    journal.add(_prediction(0), {"is_success": True})
    journal.add(_prediction(1), {"is_success": False})
    journal.close()
    with path.open("a") as fh:  # a kill in the middle of the third line
        fh.write('{"record": {"id": "x-0000')
    again = RolloutJournal(path, RUN)
    assert sorted(again.records) == ["x-000000", "x-000001"]
    again.add(_prediction(2), {"is_success": True})
    again.close()
    assert sorted(RolloutJournal(path, RUN).records) == ["x-000000", "x-000001", "x-000002"]


def test_another_runs_journal_is_refused(tmp_path: Path) -> None:
    path = journal_path(tmp_path / "p.jsonl")
    RolloutJournal(path, RUN).close()
    with pytest.raises(InvalidArgument, match=r"journal of another run.*delete the journal"):
        RolloutJournal(path, {**RUN, "policy": "noop"})
