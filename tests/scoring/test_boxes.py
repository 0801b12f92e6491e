"""IoU and box helpers: hand-computed cases, and a cross-check against shapely polygons."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from nsrmp_bench.geometry.boxes import (
    box_area,
    box_centres,
    box_intersection,
    box_iou,
    points_in_boxes,
)


@pytest.mark.parametrize(
    ("a", "b", "expected"),
    [
        ([0, 0, 10, 10], [0, 0, 10, 10], 1.0),
        ([0, 0, 10, 10], [20, 20, 30, 30], 0.0),
        ([0, 0, 10, 10], [10, 0, 20, 10], 0.0),  # touching edges: no area in common
        ([0, 0, 10, 10], [5, 0, 15, 10], 50 / 150),  # half-width shift: 1/3
        ([0, 0, 10, 10], [2, 2, 6, 6], 16 / 100),  # contained
        ([0, 0, 10, 10], [5, 5, 15, 15], 25 / 175),  # quarter overlap
        ([3, 3, 3, 3], [3, 3, 3, 3], 1.0),  # both degenerate and equal
        ([3, 3, 3, 8], [4, 3, 4, 8], 0.0),  # both degenerate, different
        ([0, 0, 0, 0], [0, 0, 10, 10], 0.0),
    ],
)
def test_iou_hand_computed(a: list[float], b: list[float], expected: float) -> None:
    assert box_iou(np.array(a), np.array(b)) == pytest.approx(expected, abs=1e-12)
    assert box_iou(np.array(b), np.array(a)) == pytest.approx(expected, abs=1e-12)


def test_iou_broadcasts_over_leading_dimensions() -> None:
    a = np.broadcast_to(np.array([0, 0, 10, 10]), (2, 3, 4))
    b = np.broadcast_to(np.array([5, 0, 15, 10]), (3, 4))
    out = box_iou(a, b)
    assert out.shape == (2, 3)
    assert np.allclose(out, 1 / 3)


def _polygon(b: np.ndarray) -> shapely.Polygon:
    return shapely.box(b[0], b[1], b[2], b[3])


def test_iou_matches_shapely_on_random_boxes() -> None:
    rng = np.random.default_rng(7)
    lo_a = rng.uniform(0, 300, (3000, 2))
    lo_b = lo_a + rng.normal(0, 30, (3000, 2))  # near each other: many overlaps
    a = np.concatenate([lo_a, lo_a + rng.uniform(0.5, 80, (3000, 2))], axis=1)
    b = np.concatenate([lo_b, lo_b + rng.uniform(0.5, 80, (3000, 2))], axis=1)
    ours = box_iou(a, b)
    pa, pb = shapely.box(a[:, 0], a[:, 1], a[:, 2], a[:, 3]), shapely.box(*b.T)
    inter = shapely.area(shapely.intersection(pa, pb))
    theirs = inter / shapely.area(shapely.union(pa, pb))
    assert np.allclose(ours, theirs, atol=1e-9)
    assert (ours > 0).sum() > 300  # the sample has many overlapping pairs


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.floats(0, 320, allow_nan=False), min_size=8, max_size=8),
)
def test_iou_matches_shapely_property(v: list[float]) -> None:
    a = np.array([min(v[0], v[1]), min(v[2], v[3]), max(v[0], v[1]), max(v[2], v[3])])
    b = np.array([min(v[4], v[5]), min(v[6], v[7]), max(v[4], v[5]), max(v[6], v[7])])
    ours = float(box_iou(a, b))
    assert 0.0 <= ours <= 1.0
    union = _polygon(a).union(_polygon(b)).area
    if union > 1e-6:
        expected = _polygon(a).intersection(_polygon(b)).area / union
        assert ours == pytest.approx(expected, abs=1e-9)
    assert float(box_intersection(a, b)) <= min(float(box_area(a)), float(box_area(b))) + 1e-9


def test_centres_and_points() -> None:
    boxes = np.array([[0, 0, 10, 20], [10, 10, 30, 30]])
    assert box_centres(boxes).tolist() == [[5, 10], [20, 20]]
    pts = np.array([[10, 20], [9.99, 31]])
    assert points_in_boxes(pts, boxes).tolist() == [True, False]  # border counts
    assert not points_in_boxes(np.array([np.nan, 5.0]), np.array([0, 0, 10, 10]))
