"""The paper's Table I and Table II, in its layout, with the paper's numbers beside ours.

Table I (IoU, IoU-M and program accuracy overall, single/double step, simple/complex) and
Table II (the CLIPort comparison: identification and placement accuracy overall, simple,
complex) are defined here as columns of figures that a results summary holds; the paper's
published rows are data (``paper_tables.json``). Our rows are every run on paper-v2/test in
the summary, in its order. "Complex" is the paper's word for relational instructions
(``relational = True``); identification and placement are over single-step instances.

The tables render as Markdown (``paper-tables.md``) and LaTeX (``paper-tables.tex``), and
can replace a marked block of a Markdown file (the documentation's results page,
``docs/results.md``) so that the figures shown there are the ones recomputed from the summary.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.summary import Results, Run
from nsrmp_bench.storage.atomic import atomic_write_text

__all__ = [
    "BLOCK_BEGIN",
    "BLOCK_END",
    "PAPER_NAMES",
    "TABLES",
    "Column",
    "PaperTable",
    "Row",
    "render_latex",
    "render_markdown",
    "replace_block",
    "row_label",
    "table_rows",
    "write_report",
]

SPLIT = "paper-v2/test"
BLOCK_BEGIN = "<!-- paper-tables:begin (nsrmp-bench report ... --readme) -->"
BLOCK_END = "<!-- paper-tables:end -->"


@dataclass(frozen=True)
class Cell:
    """One figure: a run's headline metric (category None) or a category group's."""

    metric: str
    category: str | None = None
    group: str | None = None

    def of(self, run: Run) -> float:
        """The figure of ``run`` (NaN when it does not have it)."""
        if self.category is None or self.group is None:
            return run.metric(self.metric).value
        return run.group(self.category, self.group, self.metric).value


@dataclass(frozen=True)
class Column:
    """A column of a paper table: its heading group, its label, and its figure(s)."""

    key: str
    heading: str
    label: str
    cells: tuple[Cell, ...]


@dataclass(frozen=True)
class PaperTable:
    """One of the paper's tables."""

    key: str
    title: str
    caption: str
    columns: tuple[Column, ...]


def _pair(key: str, heading: str, category: str | None, group: str | None,
          metrics: tuple[tuple[str, str, str], ...]) -> tuple[Column, ...]:
    return tuple(Column(f"{key}_{suffix}", heading, label, (Cell(metric, category, group),))
                 for suffix, label, metric in metrics)


_IOU = (("iou", "IoU", "iou"), ("iou_m", "IoU-M", "iou_m"))
_IDPL = (("id", "Id. Acc.", "identification"), ("pl", "Pl. Acc.", "placement"))

TABLE_I = PaperTable(
    "table_1", "Table I",
    "IoU and IoU-M of the final boxes and program accuracy (action / subject / predicate, "
    "all steps right), paper-v2/test; complex = relational",
    (
        *_pair("overall", "Overall", None, None, _IOU),
        Column("program", "Overall", "Program (Action/Subj/Pred)",
               (Cell("action_all_steps"), Cell("subject_all_steps"),
                Cell("predicate_all_steps"))),
        *_pair("single", "Single-step", "steps", "1", _IOU),
        *_pair("double", "Double step", "steps", "2", _IOU),
        *_pair("simple", "Simple", "relational", "False", _IOU),
        *_pair("complex", "Complex", "relational", "True", _IOU),
    ),
)
TABLE_II = PaperTable(
    "table_2", "Table II",
    "identification and placement accuracy (the CLIPort comparison), single-step "
    "instances of paper-v2/test; complex = relational",
    (
        *_pair("overall", "Overall", None, None, _IDPL),
        *_pair("simple", "Simple", "relational", "False", _IDPL),
        *_pair("complex", "Complex", "relational", "True", _IDPL),
    ),
)
TABLES = (TABLE_I, TABLE_II)


@dataclass(frozen=True)
class Row:
    """A row: its label, whether it is the paper's, and per column its figures."""

    label: str
    paper: bool
    values: tuple[tuple[float, ...], ...]


def _paper_numbers() -> dict[str, Any]:
    text = resources.files("nsrmp_bench.results").joinpath("paper_tables.json").read_text(
        "utf-8")
    data: dict[str, Any] = json.loads(text)
    return data


def _paper_row(table: PaperTable, data: dict[str, Any]) -> Row:
    values = []
    for col in table.columns:
        raw = data[col.key]
        items = raw if isinstance(raw, list) else [raw]
        if len(items) != len(col.cells):
            msg = (f"paper_tables.json {table.key} {data['model']!r}: {col.key} has "
                   f"{len(items)} numbers, the column has {len(col.cells)}")
            raise InvalidArgument(msg)
        values.append(tuple(math.nan if v is None else float(v) for v in items))
    return Row(f"paper: {data['model']}", True, tuple(values))


PAPER_NAMES = {"nsrm": "NSRM", "nmn": "NMN+"}
"""The paper's name of a model of ours (by the name part of its id), for its row label:
the paper's "Ours" is NSRM; its NMN+ baseline is ``nmn``."""


def row_label(model: str) -> str:
    """Our row's label: ``ours: NMN+ (nmn-v1)`` for a model the paper has; else the id with
    the label its shipped checkpoint's card states (``ours: dense-v1 (not CLIPort)``); else
    the id."""
    from nsrmp_bench.results.model_cards import shipped_label

    name = PAPER_NAMES.get(model.rsplit("-v", 1)[0])
    if name:
        return f"ours: {name} ({model})"
    label = shipped_label(model)
    return f"ours: {model} ({label})" if label else f"ours: {model}"


def table_rows(table: PaperTable, results: Results, *, paper: bool = True) -> list[Row]:
    """The paper's rows (when ``paper``), then one row per run on paper-v2/test."""
    rows = [_paper_row(table, d) for d in _paper_numbers()[table.key]] if paper else []
    for run in results.on(SPLIT):
        rows.append(Row(row_label(run.model), False,
                        tuple(tuple(c.of(run) for c in col.cells) for col in table.columns)))
    return rows


def _number(value: float, paper: bool) -> str:
    if not math.isfinite(value):
        return "–"
    return f"{value:.2f}" if paper else f"{value:.3f}"


def _cell(values: tuple[float, ...], paper: bool) -> str:
    return "/".join(_number(v, paper) for v in values)


def _headings(table: PaperTable) -> list[tuple[str, int]]:
    spans: list[tuple[str, int]] = []
    for col in table.columns:
        if spans and spans[-1][0] == col.heading:
            spans[-1] = (col.heading, spans[-1][1] + 1)
        else:
            spans.append((col.heading, 1))
    return spans


def render_markdown(results: Results, *, paper: bool = True) -> str:
    """Both tables as Markdown (one header row: group and label joined)."""
    lines: list[str] = []
    for table in TABLES:
        rows = table_rows(table, results, paper=paper)
        head = ["model", *(f"{c.heading} {c.label}" for c in table.columns)]
        lines += [f"**{table.title}**: {table.caption}.", "",
                  "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for row in rows:
            cells = [row.label, *(_cell(v, row.paper) for v in row.values)]
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    if not results.on(SPLIT):
        lines.append(f"(no run on {SPLIT} in the results: only the paper's rows are shown)")
        lines.append("")
    return "\n".join(lines)


def _tex(text: str) -> str:
    for a, b in (("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("_", r"\_"),
                 ("#", r"\#"), ("$", r"\$")):
        text = text.replace(a, b)
    return text


def render_latex(results: Results, *, paper: bool = True) -> str:
    """Both tables as LaTeX tabulars with the paper's multicolumn headings."""
    out: list[str] = []
    for table in TABLES:
        rows = table_rows(table, results, paper=paper)
        n = len(table.columns) + 1
        out += [r"\begin{table*}[ht]", r"    \centering",
                f"    \\caption{{{_tex(table.title)}: {_tex(table.caption)}}}",
                "    \\begin{tabular}{|" + "c|" * n + "}", r"    \hline"]
        spans = " & ".join(f"\\multicolumn{{{k}}}{{c|}}{{{_tex(h)}}}"
                           for h, k in _headings(table))
        out.append(f"    Model & {spans} \\\\")
        out.append(r"    \hline")
        labels = " & ".join(_tex(c.label) for c in table.columns)
        out.append(f"     & {labels} \\\\")
        out.append(r"    \hline")
        for row in rows:
            cells = " & ".join(_tex(_cell(v, row.paper)).replace("–", "--")
                               for v in row.values)
            out.append(f"    {_tex(row.label)} & {cells} \\\\")
            out.append(r"    \hline")
        out += [r"    \end{tabular}", r"\end{table*}", ""]
    return "\n".join(out)


def replace_block(text: str, markdown: str, where: str = "the file") -> str:
    """``text`` with the block between :data:`BLOCK_BEGIN` and :data:`BLOCK_END` replaced."""
    start, end = text.find(BLOCK_BEGIN), text.find(BLOCK_END)
    if start < 0 or end < start:
        msg = (f"{where} has no block to replace; put the lines {BLOCK_BEGIN!r} and "
               f"{BLOCK_END!r} where the tables go")
        raise InvalidArgument(msg)
    return text[: start + len(BLOCK_BEGIN)] + "\n\n" + markdown.rstrip() + "\n\n" + text[end:]


def write_report(results: Results, out: str | os.PathLike[str], *,
                 paper: bool = True) -> tuple[Path, Path]:
    """Write ``out/paper-tables.md`` and ``out/paper-tables.tex``."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    md, tex = folder / "paper-tables.md", folder / "paper-tables.tex"
    atomic_write_text(md, render_markdown(results, paper=paper))
    atomic_write_text(tex, render_latex(results, paper=paper))
    return md, tex
