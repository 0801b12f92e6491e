"""The gold table: built from episodes (rendered or symbolic) or arrays, checked."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scoring_factory import boxed_episode

import nsrmp_bench
from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import DataIntegrityError, InvalidArgument
from nsrmp_bench.scoring.gold import CATEGORY_COLUMNS, GoldTable, load_gold

INITIAL = [[100, 100, 120, 120], [200, 100, 220, 120], [50, 50, 70, 70]]
FINAL = [[100, 100, 120, 120], [100, 85, 120, 105], [50, 50, 70, 70]]


def test_layout_of_a_two_step_episode() -> None:
    ep = boxed_episode("two", [INITIAL, FINAL, FINAL], [("top", 1, 0), ("left", 2, 1)],
                       size=(640, 480))
    one = boxed_episode("one", [INITIAL, FINAL], [("right", 0, 2)])
    g = GoldTable.from_episodes([ep, one], split="s-v1")
    assert g.ids == ("two", "one") and g.split == "s-v1"
    assert g.n_objects.tolist() == [3, 3] and g.n_steps.tolist() == [2, 1]
    assert g.moved.tolist() == [False, True, True, True, False, False]
    assert g.n_moved.tolist() == [2, 1]
    assert g.actions.tolist() == [0, 1, 2] and g.subjects.tolist() == [1, 2, 0]
    assert g.image_size.tolist() == [[640, 480], [320, 240]]
    # per-step boxes: (instance, step, object); moved-so-far after step 1 = {1}, step 2 = {1, 2}
    assert g.stepbox_offsets.tolist() == [0, 6, 9]
    assert g.stepbox_moved.tolist() == [False, True, False, False, True, True,
                                        True, False, False]
    assert g.single_step.tolist() == [False, True]
    assert list(g.categories.columns) == list(CATEGORY_COLUMNS)


def test_symbolic_episodes_are_projected_with_the_official_camera() -> None:
    ep = boxed_episode("e", [INITIAL, FINAL], [("top", 1, 0)])
    g = GoldTable.from_episodes([ep.symbolic])
    assert g.image_size.tolist() == [[320, 240]]
    assert np.isfinite(g.final_boxes).all()
    assert (g.final_boxes[:, 2] >= g.final_boxes[:, 0]).all()


def test_inconsistent_data_is_refused() -> None:
    ep = boxed_episode("e", [INITIAL, FINAL], [("top", 1, 0)])
    assert ep.rendering is not None
    t = ep.rendering.targets
    first_only = replace(t, poses=t.poses[:1], boxes_amodal=t.boxes_amodal[:1])
    short = Episode(ep.symbolic, replace(ep.rendering, targets=first_only))
    with pytest.raises(DataIntegrityError, match="episode e: its boxes have shape"):
        GoldTable.from_episodes([short])
    with pytest.raises(DataIntegrityError, match="'e' occurs more than once"):
        GoldTable.from_episodes([ep, ep])


def test_build_checks_shapes() -> None:
    ok = {
        "ids": ["a"], "n_objects": np.array([2]), "n_steps": np.array([1]),
        "initial_boxes": np.zeros((2, 4)), "final_boxes": np.zeros((2, 4)),
        "final_positions": np.zeros((2, 3)), "actions": ["top"], "subjects": np.array([0]),
        "references": np.array([1]), "step_boxes": np.zeros((2, 4)),
        "image_size": np.array([[320, 240]]),
    }
    g = GoldTable.build(**ok)
    assert list(g.categories.columns) == ["steps", "objects"]
    for key, bad, match in [
        ("final_boxes", np.zeros((3, 4)), "final_boxes has 3 rows"),
        ("actions", ["jump"], "'jump' is not one of"),
        ("subjects", np.array([2]), "subjects must be object indices"),
        ("step_boxes", np.zeros((1, 4)), "step_boxes has 1 rows"),
        ("initial_boxes", np.zeros((2, 3)), r"shape \(n, 4\)"),
    ]:
        with pytest.raises(InvalidArgument, match=match):
            GoldTable.build(**{**ok, key: bad})
    with pytest.raises(InvalidArgument, match="categories have 2 rows"):
        GoldTable.build(**ok, categories=pd.DataFrame({"x": [1, 2]}))


def test_load_gold_paths() -> None:
    with pytest.raises(InvalidArgument, match="does not exist"):
        load_gold("/nonexistent/data.h5")
    g = GoldTable.from_episodes([])
    assert load_gold(g) is g and len(g) == 0


def test_score_is_reexported_lazily() -> None:
    from nsrmp_bench.scoring.scorer import score

    assert nsrmp_bench.score is score
