"""The generalisation figures from the committed runs: every file written, the same bytes
twice, the plotted points are the summary's, and what cannot be drawn is refused."""

from __future__ import annotations

from pathlib import Path

import pytest
from site_build import SITE

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.figures import FIGURES, category_bars, curves, draw_figures
from nsrmp_bench.results.summary import Results

pytest.importorskip("matplotlib")

NAMES = ("iou_m_by_objects", "iou_m_by_steps", "iou_m_by_category")


def test_figures_are_written_as_png_and_svg_and_are_deterministic(tmp_path: Path) -> None:
    results = Results.read(SITE)
    first = draw_figures(results, tmp_path / "a", NAMES)
    second = draw_figures(results, tmp_path / "b", NAMES)
    assert sorted(p.name for p in first) == sorted(f"{n}.{s}" for n in NAMES
                                                   for s in ("png", "svg"))
    for a, b in zip(first, second, strict=True):
        assert a.read_bytes() == b.read_bytes(), a.name
        if a.suffix == ".png":
            assert a.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and a.stat().st_size > 20_000
        else:
            assert b"<svg" in a.read_bytes()[:600]


def test_curves_join_the_training_range_and_the_held_out_split() -> None:
    results = Results.read(SITE)
    objects = {c.model: c for c in curves(results, FIGURES[0])}
    nsrm = objects["nsrm-v1"]
    paper = results.run("nsrm-v1", "paper-v2/test")
    held = results.run("nsrm-v1", "objects-v2/test")
    assert paper is not None and held is not None
    expected = {int(g): e for g, e in paper.groups("objects", "iou_m")}
    expected.update({int(g): e for g, e in held.groups("objects", "iou_m")})
    assert nsrm.xs == tuple(sorted(expected))
    assert nsrm.estimates == tuple(expected[x] for x in nsrm.xs)
    assert objects["oracle-v1"].xs == nsrm.xs  # the baselines have entries on both parts


def test_category_bars_are_the_summary_figures() -> None:
    results = Results.read(SITE)
    bars = category_bars(results)
    nsrm = bars["nsrm-v1"]
    language = results.run("nsrm-v1", "language-v2/test")
    paper = results.run("nsrm-v1", "paper-v2/test")
    assert language is not None and paper is not None
    assert nsrm[6] == language.metric("iou_m")
    assert nsrm[2] == paper.group("relational", "True", "iou_m")
    oracle = results.run("oracle-v1", "language-v2/test")
    assert oracle is not None and bars["oracle-v1"][6] == oracle.metric("iou_m")


def test_nothing_to_draw_and_unknown_names_are_refused(tmp_path: Path) -> None:
    results = Results.read(SITE)
    with pytest.raises(InvalidArgument, match=r"nothing to plot.*runs here: \[\]"):
        draw_figures(Results(()), tmp_path)
    with pytest.raises(InvalidArgument, match=r"unknown figure\(s\) \['x'\]"):
        draw_figures(results, tmp_path, names=["x"])


def test_a_model_without_a_held_out_run_gets_a_gap_not_a_zero() -> None:
    results = Results.read(SITE)
    dropped = Results(tuple(r for r in results.runs
                            if not (r.model == "oracle-v1" and r.split == "language-v2/test")))
    assert category_bars(dropped)["oracle-v1"][6].n == 0
    assert category_bars(results)["oracle-v1"][6].n > 0
