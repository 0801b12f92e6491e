"""The metrics against hand-computed values: stacked and occluded objects, programs,
identification and placement (without the original's centre bug), success, per-step IoU-M,
and missing predictions."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scoring_factory import HEADER, SPLIT, boxed_episode, prediction

from nsrmp_bench.episode import Episode
from nsrmp_bench.scoring import ScoreResult, parse_predictions, score
from nsrmp_bench.scoring.submission import Prediction

# Three objects; object 1 is put on top of object 0 (its box overlaps 0's top by 5 px).
INITIAL = [[100, 100, 120, 120], [200, 100, 220, 120], [50, 50, 70, 70]]
STACKED = [[100, 100, 120, 120], [100, 85, 120, 105], [50, 50, 70, 70]]


def run(episodes: list[Episode], preds: list[Prediction], **kw: Any) -> ScoreResult:
    sub = parse_predictions(HEADER, preds)
    return score(sub, episodes, split=SPLIT, n_boot=0, **kw)


def inst(result: ScoreResult, eid: str, metric: str) -> float:
    return float(result.per_instance.at[eid, metric])


@pytest.fixture
def stacked() -> Episode:
    return boxed_episode("stack", [INITIAL, STACKED], [("top", 1, 0)])


def test_perfect_prediction_scores_one(stacked: Episode) -> None:
    r = run([stacked], [prediction("stack", STACKED, program=[("top", 1, 0)])])
    for m in ("iou", "iou_m", "success", "program_exact", "identification", "placement"):
        assert r.value(m) == 1.0, m


def test_stacked_objects_swapped_boxes(stacked: Episode) -> None:
    # Boxes of the stacked pair swapped: each overlaps its gold box by 20 x 5 = 100 px^2,
    # union 400 + 400 - 100 = 700, so IoU 1/7 for both; object 2 stays exact.
    swapped = [STACKED[1], STACKED[0], STACKED[2]]
    r = run([stacked], [prediction("stack", swapped)])
    assert r.value("iou") == pytest.approx((1 / 7 + 1 / 7 + 1) / 3)
    assert r.value("iou_m") == pytest.approx(1 / 7)  # only object 1 moved
    assert r.value("success_2d") == 0.0


def test_noop_on_stacking_scores_the_unmoved_share(stacked: Episode) -> None:
    r = run([stacked], [prediction("stack", INITIAL, program=[])])
    assert r.value("iou") == pytest.approx(2 / 3)  # (N - k) / N with N = 3, k = 1
    assert r.value("iou_m") == 0.0
    assert r.value("program_exact") == 0.0


def test_noop_floor_is_n_minus_k_over_n() -> None:
    initial = [[10 + 40 * i, 10, 30 + 40 * i, 30] for i in range(5)]
    final = [row[:] for row in initial]
    final[3] = [100, 150, 120, 170]  # moved somewhere disjoint from where it was
    ep = boxed_episode("floor", [initial, final], [("left", 3, 1)])
    r = run([ep], [prediction("floor", initial)])
    assert r.value("iou") == pytest.approx(4 / 5)
    assert r.value("iou_m") == 0.0


@pytest.mark.parametrize(
    ("pred_box", "iou", "success"),
    [
        ([60, 40, 80, 70], 1.0, 1.0),  # the amodal box: full credit though half hidden
        ([60, 40, 80, 55], 0.5, 1.0),  # the visible half only: IoU 300/600, success at >= 0.5
        ([60, 40, 80, 54], 280 / 600, 0.0),  # just under
    ],
)
def test_occluded_object_is_scored_on_its_amodal_box(
    pred_box: list[float], iou: float, success: float
) -> None:
    # Object 2 ends behind object 1, whose box hides the lower half of 2's amodal box.
    initial = [[10, 100, 30, 120], [60, 55, 80, 80], [200, 40, 220, 70]]
    final = [[10, 100, 30, 120], [60, 55, 80, 80], [60, 40, 80, 70]]
    ep = boxed_episode("occ", [initial, final], [("left", 2, 0)])
    r = run([ep], [prediction("occ", [final[0], final[1], pred_box])])
    assert r.value("iou_m") == pytest.approx(iou)
    assert r.value("success_2d") == success


GOLD_TWO = [("top", 1, 0), ("left", 2, 1)]


@pytest.mark.parametrize(
    ("program", "per_step", "all_steps", "exact"),
    [
        # (action, subject, predicate) per step; then all-steps; then exact
        (GOLD_TWO, (1, 1, 1), (1, 1, 1), 1),
        ([("top", 1, 0)], (0.5, 0.5, 0.5), (0, 0, 0), 0),  # a step missing
        ([("top", 1, 0), ("left", 2, 0)], (1, 1, 0.5), (1, 1, 0), 0),  # wrong reference
        ([("right", 1, 0), ("left", 2, 1)], (0.5, 1, 1), (0, 1, 1), 0),  # wrong action
        ([*GOLD_TWO, ("top", 0, 2)], (2 / 3, 2 / 3, 2 / 3), (0, 0, 0), 0),  # a step too many
        ([("top", 2, 1), ("left", 1, 0)], (1, 0, 0), (1, 0, 0), 0),  # steps swapped
        ([], (0, 0, 0), (0, 0, 0), 0),  # predicts no step
        (None, (0, 0, 0), (0, 0, 0), 0),  # no program at all
    ],
)
def test_program_accuracy(
    program: list[tuple[str, int, int]] | None,
    per_step: tuple[float, float, float],
    all_steps: tuple[float, float, float],
    exact: float,
) -> None:
    boxes = [INITIAL, STACKED, STACKED]
    ep = boxed_episode("two", boxes, GOLD_TWO)
    r = run([ep], [prediction("two", STACKED, program=program)])
    for name, ps, al in zip(("action", "subject", "predicate"), per_step, all_steps, strict=True):
        assert r.value(f"{name}_per_step") == pytest.approx(ps), name
        assert r.value(f"{name}_all_steps") == al, name
    assert r.value("program_exact") == exact


# Single step: object 1 goes left of object 0.
ID_INITIAL = [[100, 100, 120, 120], [200, 100, 220, 120], [10, 10, 30, 30]]
ID_FINAL = [[100, 100, 120, 120], [150, 100, 170, 120], [10, 10, 30, 30]]


@pytest.fixture
def single() -> Episode:
    return boxed_episode("one", [ID_INITIAL, ID_FINAL], [("left", 1, 0)])


@pytest.mark.parametrize(
    ("fields", "identified"),
    [
        ({"pick": (210.0, 110.0)}, 1.0),  # inside the moved object's initial box
        ({"pick": (220.0, 120.0)}, 1.0),  # on its border
        ({"pick": (110.0, 110.0)}, 0.0),  # on another object
        ({"program": [("left", 1, 0)]}, 1.0),  # no pick: the program's subject
        ({"program": [("left", 0, 1)]}, 0.0),  # the wrong subject
        ({}, 0.0),  # neither pick nor program
    ],
)
def test_identification(single: Episode, fields: dict[str, Any], identified: float) -> None:
    r = run([single], [prediction("one", ID_FINAL, **fields)])
    assert r.value("identification") == identified


@pytest.mark.parametrize(
    ("moved_box", "fields", "placed"),
    [
        (ID_FINAL[1], {"place": (160.0, 119.0)}, 1.0),
        (ID_FINAL[1], {"place": (149.0, 110.0)}, 0.0),
        (ID_FINAL[1], {}, 1.0),  # the predicted box's centre
        # Centre (160, 125) lies below the gold box; the original's bug took the centre's y
        # from the predicted y1 and the gold y2, (120 + 120) / 2 = 120, and counted it.
        ([150, 120, 170, 130], {}, 0.0),
        # Centre (160, 105) is inside; the buggy y (60 + 120) / 2 = 90 would miss it.
        ([150, 60, 170, 150], {}, 1.0),
    ],
)
def test_placement_uses_the_true_centre(
    single: Episode, moved_box: list[float], fields: dict[str, Any], placed: float
) -> None:
    boxes = [ID_FINAL[0], moved_box, ID_FINAL[2]]
    r = run([single], [prediction("one", boxes, **fields)])
    assert r.value("placement") == placed


def test_identification_only_on_single_step(single: Episode) -> None:
    two = boxed_episode("two", [INITIAL, STACKED, STACKED], GOLD_TWO)
    r = run([single, two], [prediction("one", ID_FINAL, pick=(210.0, 110.0)),
                            prediction("two", STACKED)])
    assert math.isnan(inst(r, "two", "identification"))
    assert r.summary.at["identification", "n"] == 1
    assert r.value("identification") == 1.0


def test_success_3d_within_two_centimetres() -> None:
    pos = np.zeros((2, 3, 3))
    pos[:, :, 0] = [0.0, 0.1, 0.2]
    pos[1, 1] = [0.0, 0.0, 0.05]  # object 1 ends on top of object 0
    ep = boxed_episode("p", [INITIAL, STACKED], [("top", 1, 0)], positions=pos)
    near = pos[1].copy()
    near[1] += [0.011, 0.0, 0.011]  # 1.56 cm away
    far = pos[1].copy()
    far[1] += [0.0, 0.021, 0.0]
    far[0] += [0.5, 0.0, 0.0]  # an unmoved object's position does not matter
    ep2 = boxed_episode("q", [INITIAL, STACKED], [("top", 1, 0)], positions=pos)
    ep3 = boxed_episode("r", [INITIAL, STACKED], [("top", 1, 0)], positions=pos)
    r = run([ep, ep2, ep3], [prediction("p", STACKED, positions=near),
                             prediction("q", STACKED, positions=far),
                             prediction("r", STACKED)])
    assert inst(r, "p", "success") == 1.0
    assert inst(r, "q", "success") == 0.0
    assert inst(r, "q", "success_2d") == 1.0
    assert inst(r, "r", "success") == 1.0  # no positions given: 2D criterion only
    assert inst(r, "r", "success_3d") == 0.0  # and 0 on the 3D figure
    assert r.summary.at["success_3d", "n"] == 3


def test_success_3d_not_reported_without_positions(stacked: Episode) -> None:
    r = run([stacked], [prediction("stack", STACKED)])
    assert r.summary.at["success_3d", "n"] == 0
    assert math.isnan(r.value("success_3d"))


def test_per_step_iou_m() -> None:
    state1 = STACKED
    state2 = [STACKED[0], STACKED[1], [100, 150, 120, 170]]
    ep = boxed_episode("steps", [INITIAL, state1, state2], GOLD_TWO)
    off = [STACKED[0], STACKED[1], [110, 150, 130, 170]]  # object 2 off by half: IoU 1/3
    r = run([ep], [prediction("steps", state2, step_boxes=np.array([state1, off]))])
    assert r.per_step.at[1, "value"] == 1.0  # objects moved by step 1: {1}
    assert r.per_step.at[2, "value"] == pytest.approx((1 + 1 / 3) / 2)  # {1, 2}
    assert r.value("iou_m") == 1.0  # final boxes are scored from 'boxes'


def test_per_step_iou_m_absent_without_step_boxes(stacked: Episode) -> None:
    r = run([stacked], [prediction("stack", STACKED)])
    assert len(r.per_step) == 0


def test_missing_predictions_score_zero_and_are_counted(stacked: Episode) -> None:
    other = boxed_episode("other", [INITIAL, STACKED], [("top", 1, 0)])
    r = run([stacked, other], [prediction("stack", STACKED, program=[("top", 1, 0)])])
    assert r.counts["missing"] == 1
    assert r.counts["instances"] == 2
    assert not r.per_instance.at["other", "present"]
    for m in ("iou", "iou_m", "success", "program_exact", "subject_per_step", "placement"):
        assert inst(r, "other", m) == 0.0
        assert r.value(m) == 0.5
        assert r.summary.at[m, "n"] == 2
    assert any("no prediction" in w for w in r.warnings)


def test_breakdown_and_paper_table() -> None:
    eps = [
        boxed_episode("a", [INITIAL, STACKED], [("top", 1, 0)], relational=False),
        boxed_episode("b", [INITIAL, STACKED], [("top", 1, 0)], relational=True,
                      phrasing="complex", template="T02"),
        boxed_episode("c", [INITIAL, STACKED, STACKED], GOLD_TWO, relational=True),
    ]
    preds = [prediction("a", STACKED), prediction("b", INITIAL), prediction("c", STACKED)]
    r = run(eps, preds)
    by = r.breakdown("iou_m")
    assert by.loc[("relational", "False"), "value"] == 1.0
    assert by.loc[("relational", "True"), "value"] == pytest.approx(0.5)
    assert by.loc[("relational", "True"), "n"] == 2
    assert by.loc[("phrasing", "complex"), "value"] == 0.0
    assert by.loc[("steps", "2"), "value"] == 1.0
    table = r.paper_table()
    assert table.loc["single-step", "IoU-M"] == pytest.approx(0.5)
    assert table.loc["complex", "n"] == 2
    assert set(r.per_category["category"]) >= {"steps", "objects", "relational",
                                               "relation_needed", "phrasing", "template"}
