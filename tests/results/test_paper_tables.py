"""The paper's Table I and II: its published numbers beside ours, as Markdown, LaTeX and the
the results page's block (docs/results.md), every number of ours read from the results summary."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from importlib import resources
from pathlib import Path

import pytest
from site_build import REPO, SITE

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.paper_tables import (
    BLOCK_BEGIN,
    BLOCK_END,
    TABLE_I,
    TABLE_II,
    render_latex,
    render_markdown,
    replace_block,
    row_label,
    table_rows,
)
from nsrmp_bench.results.summary import Results


def _paper() -> dict[str, list[dict[str, object]]]:
    text = resources.files("nsrmp_bench.results").joinpath("paper_tables.json").read_text()
    data: dict[str, list[dict[str, object]]] = json.loads(text)
    return data


def _markdown_rows(text: str, title: str) -> dict[str, list[str]]:
    block = text.split(f"**{title}**", 1)[1].split("\n\n", 2)[1]
    rows = {}
    for line in block.splitlines()[2:]:
        cells = [c.strip() for c in line.strip("|").split("|")]
        rows[cells[0]] = cells[1:]
    return rows


def test_table_i_paper_rows_then_ours_from_the_summary() -> None:
    results = Results.read(SITE)
    md = render_markdown(results, paper=True)
    rows = _markdown_rows(md, "Table I")
    for published in _paper()["table_1"]:
        cells = rows[f"paper: {published['model']}"]
        assert cells[0] == f"{published['overall_iou']:.2f}"
        assert cells[2] == "/".join("–" if v is None else f"{v:.2f}"
                                    for v in published["program"])  # type: ignore[attr-defined]
    ours = results.on("paper-v2/test")
    assert ours
    for run in ours:
        cells = rows[row_label(run.model)]
        assert cells[1] == f"{run.metric('iou_m').value:.3f}"
        assert cells[2] == "/".join(f"{run.metric(m).value:.3f}" for m in
                                    ("action_all_steps", "subject_all_steps",
                                     "predicate_all_steps"))
        assert cells[4] == f"{run.group('steps', '1', 'iou_m').value:.3f}"
        assert cells[10] == f"{run.group('relational', 'True', 'iou_m').value:.3f}"
    assert len(rows) == len(_paper()["table_1"]) + len(ours)


def test_table_ii_is_identification_and_placement_by_relational() -> None:
    results = Results.read(SITE)
    run = results.run("nsrm-v1", "paper-v2/test")
    assert run is not None
    row = next(r for r in table_rows(TABLE_II, results) if r.label == "ours: NSRM (nsrm-v1)")
    assert row.values[0] == (run.metric("identification").value,)
    assert row.values[5] == (run.group("relational", "True", "placement").value,)
    md = _markdown_rows(render_markdown(results, paper=False), "Table II")
    assert all(label.startswith("ours: ") for label in md)


def test_latex_has_the_paper_layout() -> None:
    tex = render_latex(Results.read(SITE), paper=True)
    assert tex.count(r"\begin{tabular}") == 2
    assert r"\multicolumn{3}{c|}{Overall} & \multicolumn{2}{c|}{Single-step}" in tex
    assert r"paper: NMN+ (gold BB) & 0.77 & 0.55 & --/0.81/0.76" in tex
    assert len(TABLE_I.columns) + 1 == tex.split(r"\begin{tabular}{|", 1)[1].split("}")[0].count("c")


def test_without_paper_rows_shows_ours_only_and_says_when_there_are_none() -> None:
    empty = Results(())
    md = render_markdown(empty, paper=True)
    assert "no run on paper-v2/test" in md
    assert [r.paper for r in table_rows(TABLE_I, empty)] == [True] * len(_paper()["table_1"])
    assert table_rows(TABLE_I, empty, paper=False) == []
    published = table_rows(TABLE_I, empty)[0]
    assert math.isnan(published.values[2][0])  # NMN+ has no action accuracy: "--"


def test_results_page_block_is_the_report_of_the_committed_runs() -> None:
    readme = (REPO / "docs" / "results.md").read_text()
    expected = replace_block(readme, render_markdown(Results.read(SITE), paper=True))
    assert readme == expected, (
        "docs/results.md's paper tables are stale: run "
        "`nsrmp-bench report leaderboards/site --paper --readme docs/results.md`")


def test_report_cli_writes_md_tex_and_replaces_the_block(tmp_path: Path) -> None:
    readme = tmp_path / "R.md"
    readme.write_text(f"# x\n{BLOCK_BEGIN}\nSTALE-LINE\n{BLOCK_END}\ntail\n")
    out = tmp_path / "out"
    subprocess.run([sys.executable, "-m", "nsrmp_bench.cli.main", "report", str(SITE),
                    "--paper", "--out", str(out), "--readme", str(readme), "--quiet"],
                   check=True, timeout=120)
    md = (out / "paper-tables.md").read_text()
    assert md == render_markdown(Results.read(SITE), paper=True)
    assert (out / "paper-tables.tex").read_text().startswith(r"\begin{table*}")
    text = readme.read_text()
    assert "STALE-LINE" not in text and md.strip() in text and text.endswith("tail\n")
    with pytest.raises(InvalidArgument, match=r"has no block to replace"):
        replace_block("no markers", md)


def test_rows_carry_the_registered_label() -> None:
    from nsrmp_bench.results.paper_tables import row_label

    assert row_label("dense-v1") == "ours: dense-v1 (not CLIPort)"
    assert row_label("dense5x-v1") == "ours: dense5x-v1 (not CLIPort, 5x data)"
    assert row_label("nsrm-v1") == "ours: NSRM (nsrm-v1)"
    assert row_label("my-submission") == "ours: my-submission"
