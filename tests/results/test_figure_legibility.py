"""The figures read well: every model keeps one colour everywhere, the legend sits outside
the axes and inside the image even with twelve models, the reference rows are grey lines
rather than series, more than six models split into one panel per protocol, the value axis
fits the models, and ``plot`` draws a part of its own (smoke-v2)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest
from site_build import SITE

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.colours import PALETTE, REFERENCE_STYLES, model_styles
from nsrmp_bench.results.figures import MAX_CURVES, draw_figures, figure_names, render
from nsrmp_bench.results.label_place import label_overlaps
from nsrmp_bench.results.protocols import DENSE, DETECTED, GOLD, protocol_of
from nsrmp_bench.results.summary import Results

pytest.importorskip("matplotlib")

EXTRA = ("sub-a-v1", "sub-b-v1", "sub-c-v1", "sub-d-v1")


def _twelve() -> Results:
    """The committed runs plus four more models (copies of nsrm-v1's runs under new
    ids, two on detected boxes): at least twelve models and three reference rows."""
    committed = Results.read(SITE)
    runs = list(committed.runs)
    for i, model in enumerate(EXTRA):
        source = "nsrm-v1+detector-v1" if i % 2 else "nsrm-v1"
        runs += [dataclasses.replace(r, model=model) for r in committed.runs
                 if r.model == source and r.split != "smoke-v2/test"]
    results = Results(tuple(runs))
    assert len([m for m in results.models if not m.endswith(("oracle-v1", "noop-v1",
                                                             "random-v1"))]) >= 12
    return results


def _legend_texts(fig: Any) -> list[Any]:
    return [t for legend in fig.legends for t in legend.get_texts()]


@pytest.mark.parametrize("name", ["iou_m_by_objects", "iou_m_by_steps", "iou_m_by_category"])
def test_twelve_models_every_legend_label_inside_the_image_and_off_the_axes(name: str) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    results = _twelve()
    fig = render(results, name)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    width, height = canvas.get_width_height()
    texts = _legend_texts(fig)
    labels = {t.get_text() for t in texts}
    assert labels == {*(m for m in results.models if m not in REFERENCE_STYLES),
                      *(f"{m} (reference)" for m in REFERENCE_STYLES)}
    for text in texts:
        box = text.get_window_extent(renderer)
        assert box.x0 >= 0 and box.y0 >= 0 and box.x1 <= width and box.y1 <= height, \
            (text.get_text(), box, width, height)
    for legend in fig.legends:
        frame = legend.get_window_extent(renderer)
        for ax in fig.axes:
            assert not frame.overlaps(ax.get_window_extent(renderer)), "legend covers data"


def test_more_than_six_models_become_one_panel_per_protocol() -> None:
    results = _twelve()
    fig = render(results, "iou_m_by_objects")
    assert [ax.get_title() for ax in fig.axes] == [GOLD, DETECTED, DENSE]
    committed = Results(tuple(r for r in Results.read(SITE).runs
                              if r.model in {"nsrm-v1", "nmn-v1", "oracle-v1"}))
    single = render(committed, "iou_m_by_objects")
    assert len(single.axes) == 1 and MAX_CURVES >= 2


def test_references_are_grey_lines_and_the_scale_fits_the_models() -> None:
    results = Results.read(SITE)
    fig = render(results, "iou_m_by_objects")
    colours = {s.colour for s in model_styles(results.models).values()}
    greys = {s.colour for s in REFERENCE_STYLES.values()}
    for ax in fig.axes:
        _low, high = ax.get_ylim()
        # the models set the scale (their highest interval end plus a margin); the
        # oracle's 1.0 stays above it (a threshold of 0.95 held until nsrm-v2's best
        # curve reached 0.89)
        assert high < 1.0, "the oracle at 1.0 sets the scale"
        texts = [t.get_text() for t in ax.texts]
        assert any(t.startswith("oracle-v1 ") and "above the scale" in t for t in texts)
        for line in ax.get_lines():
            if line.get_linestyle() in {"--", ":", "-."} and line.get_xydata().shape[0] > 2:
                assert line.get_color() in greys | {"#444444"}
        drawn = {line.get_color() for line in ax.get_lines() if line.get_marker() != "None"}
        assert drawn <= colours


def test_one_colour_per_model_everywhere() -> None:
    shipped = model_styles(["nsrm-v1", "nmn-v1", "dense-v1"])
    assert model_styles(["nsrm-v1", "zz-v1", "aa-v1"])["nsrm-v1"] == shipped["nsrm-v1"]
    many = model_styles([f"m{i:02d}-v1" for i in range(30)])
    assert len({(s.colour, s.marker) for s in many.values()}) == 30
    twenty = model_styles([f"m{i:02d}-v1" for i in range(len(PALETTE))])
    assert {s.colour for s in twenty.values()} == set(PALETTE)  # a colour each


@pytest.mark.parametrize("name", ["iou_m_by_objects", "iou_m_by_steps", "iou_m_by_category",
                                  "iou_m_by_objects--smoke-v2-test"])
def test_every_model_of_a_figure_has_a_colour_of_its_own(name: str) -> None:
    results = Results.read(SITE)
    fig = render(results, name)
    handles = [h for legend in fig.legends for h in legend.legend_handles]
    labels = [t.get_text() for t in _legend_texts(fig)]
    colours = {}
    for handle, label in zip(handles, labels, strict=True):
        if not label.endswith("(reference)"):
            face = getattr(handle, "get_facecolor", None)
            colour = handle.get_color() if hasattr(handle, "get_color") else face()
            colours[label] = str(colour)
    assert len(colours) >= 10 and len(set(colours.values())) == len(colours), colours


@pytest.mark.parametrize("name", ["iou_m_by_objects", "iou_m_by_steps", "iou_m_by_category",
                                  "iou_m_by_objects--smoke-v2-test",
                                  "iou_m_by_steps--smoke-v2-test"])
def test_no_label_is_overprinted(name: str) -> None:
    """Reference names, off-scale notes and the train-range marks sit clear of every data
    line, marker, bar and other label (a reference's name may touch its own line)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    for results in (Results.read(SITE), _twelve()):
        if name not in figure_names(results):
            continue
        fig = render(results, name)
        FigureCanvasAgg(fig).draw()
        assert label_overlaps(fig) == [], name


def test_protocol_comes_from_the_scorer_counts() -> None:
    results = Results.read(SITE)
    got = {r.model: protocol_of(r.model, r.counts) for r in results.on("paper-v2/test")}
    assert got["nsrm-v1"].name == GOLD
    assert got["nsrm-v1+detector-v1"].label == "detected boxes (detector-v1)"
    assert got["dense-v1"].name == DENSE
    assert got["noop-v1"].name == GOLD


def test_plot_draws_the_smoke_part_on_its_own(tmp_path: Path) -> None:
    smoke = Results(tuple(Results.read(SITE).on("smoke-v2/test")))
    names = figure_names(smoke)
    assert names[3:] == ["iou_m_by_objects--smoke-v2-test", "iou_m_by_steps--smoke-v2-test",
                         "iou_m_by_category--smoke-v2-test"]
    written = draw_figures(smoke, tmp_path)
    assert sorted(p.name for p in written) == sorted(f"{n}.{s}" for n in names[3:]
                                                     for s in ("png", "svg"))
    with pytest.raises(InvalidArgument, match="nothing to plot"):
        draw_figures(Results(()), tmp_path)
