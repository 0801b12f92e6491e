"""scorer-v2: kept still, strict success and abstention against hand-computed values; the
``abstain`` field read alike in bulk and line by line; bad abstentions refused with the
line named (exit 2); scorer-v1 gives exactly its own table."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scoring_factory import HEADER, SPLIT, boxed_episode, prediction
from test_bulk_read import assert_same, bulk, line_by_line

from nsrmp_bench.cli.main import main
from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument, SubmissionError
from nsrmp_bench.scoring import ScoreResult, parse_predictions, score
from nsrmp_bench.scoring.compare import compare
from nsrmp_bench.scoring.gold import GoldTable
from nsrmp_bench.scoring.metrics import METRICS, METRICS_V2
from nsrmp_bench.scoring.reader import read_submission
from nsrmp_bench.scoring.submission import Prediction, SubmissionHeader, write_submission

# Three objects; object 1 is put on top of object 0; object 2 stays where it is.
INITIAL = [[100, 100, 120, 120], [200, 100, 220, 120], [50, 50, 70, 70]]
STACKED = [[100, 100, 120, 120], [100, 85, 120, 105], [50, 50, 70, 70]]
# The same, and object 2 moved far away as well.
EXTRA = [[100, 100, 120, 120], [100, 85, 120, 105], [250, 180, 270, 200]]
V2_ONLY = {"success_strict", "kept_still", "abstention"}


def run(episodes: list[Episode] | GoldTable, preds: list[Prediction], **kw: Any) -> ScoreResult:
    return score(parse_predictions(HEADER, preds), episodes, split=SPLIT, n_boot=0, **kw)


def inst(result: ScoreResult, eid: str, metric: str) -> float:
    return float(result.per_instance.at[eid, metric])


@pytest.fixture
def stacked() -> Episode:
    return boxed_episode("stack", [INITIAL, STACKED], [("top", 1, 0)])


def with_abstain(episodes: list[Episode], values: list[str | None]) -> GoldTable:
    gold = GoldTable.from_episodes(episodes, split=SPLIT)
    return dataclasses.replace(gold, abstain=GoldTable.build(
        ids=gold.ids, n_objects=gold.n_objects, n_steps=gold.n_steps,
        initial_boxes=gold.initial_boxes, final_boxes=gold.final_boxes,
        final_positions=gold.final_positions, actions=gold.actions, subjects=gold.subjects,
        references=gold.references, step_boxes=gold.step_boxes, image_size=gold.image_size,
        abstain=values).abstain)


def test_an_extra_moved_object_fails_strict_success_only(stacked: Episode) -> None:
    right = run([stacked], [prediction("stack", STACKED, program=[("top", 1, 0)])])
    extra = run([stacked], [prediction("stack", EXTRA, program=[("top", 1, 0)])])
    v1 = run([stacked], [prediction("stack", EXTRA, program=[("top", 1, 0)])],
             scorer="scorer-v1")
    assert inst(right, "stack", "success") == inst(extra, "stack", "success") == 1.0
    assert inst(v1, "stack", "success") == 1.0
    assert inst(right, "stack", "success_strict") == 1.0
    assert inst(right, "stack", "kept_still") == 1.0
    assert inst(extra, "stack", "success_strict") == 0.0
    assert inst(extra, "stack", "kept_still") == 0.5  # objects 0 and 2 stay put; 2 moved
    assert math.isnan(inst(extra, "stack", "abstention"))  # the gold does not abstain


def test_kept_still_is_a_share_and_tests_positions() -> None:
    initial = [*INITIAL, [10, 10, 30, 30]]
    final = [*STACKED, [10, 10, 30, 30]]
    ep = boxed_episode("four", [initial, final], [("top", 1, 0)])
    moved_one = [*STACKED, [150, 150, 170, 170]]
    r = run([ep], [prediction("four", moved_one)])
    assert inst(r, "four", "kept_still") == pytest.approx(2 / 3)  # objects 0, 2 kept; 3 moved
    assert inst(r, "four", "success_strict") == 0.0
    # Positions given: object 2's centre 5 cm off fails it although its box is right.
    gold_pos = np.zeros((4, 3))
    gold_pos[:, 0] = np.arange(4) * 0.1
    pos = gold_pos.copy()
    pos[2, 1] += 0.05
    r = run([ep], [prediction("four", final, positions=pos)])
    assert inst(r, "four", "kept_still") == pytest.approx(2 / 3)
    assert inst(r, "four", "success") == 1.0 and inst(r, "four", "success_strict") == 0.0


def test_missing_and_everything_moved() -> None:
    final = [[10, 10, 30, 30], [100, 85, 120, 105]]
    all_moved = boxed_episode("all", [INITIAL[:2], STACKED[:2], final],
                              [("top", 1, 0), ("left", 0, 1)])
    two = boxed_episode("two", [INITIAL, STACKED], [("top", 1, 0)])
    r = run([all_moved, two], [prediction("all", final)])
    assert math.isnan(inst(r, "all", "kept_still"))  # the gold leaves nothing in place
    assert inst(r, "all", "success_strict") == 1.0
    assert inst(r, "two", "kept_still") == 0.0 and inst(r, "two", "success_strict") == 0.0
    assert r.summary.at["kept_still", "n"] == 1


def test_a_gold_that_moves_nothing_has_strict_success() -> None:
    still = boxed_episode("still", [INITIAL], [])
    r = run([still], [prediction("still", INITIAL, program=[])])
    assert inst(r, "still", "success_strict") == 1.0
    assert inst(r, "still", "kept_still") == 1.0
    assert math.isnan(inst(r, "still", "iou_m"))
    r = run([still], [prediction("still", EXTRA, program=[("top", 1, 0)])])
    assert inst(r, "still", "success") == 1.0  # vacuous: nothing to move
    assert inst(r, "still", "success_strict") == 0.0
    assert inst(r, "still", "kept_still") == pytest.approx(1 / 3)  # only object 0 stayed


@pytest.mark.parametrize(("gold", "fields", "boxes", "right"), [
    ("no action", {"abstain": "no action"}, INITIAL, 1.0),
    ("no action", {"abstain": "not feasible"}, INITIAL, 0.0),
    ("not feasible", {"abstain": "not feasible"}, INITIAL, 1.0),
    ("no action", {"program": []}, INITIAL, 1.0),  # an empty program: no action
    ("no action", {"program": []}, EXTRA, 1.0),  # decided by the program, not the boxes
    ("not feasible", {"program": []}, INITIAL, 0.0),
    ("no action", {}, INITIAL, 1.0),  # no program, every box kept still
    ("no action", {}, EXTRA, 0.0),  # no program, a box moved: it acts
    ("no action", {"program": [("top", 1, 0)]}, INITIAL, 0.0),  # acts
    (None, {"abstain": "no action"}, INITIAL, math.nan),  # the gold does not abstain
])
def test_abstention(gold: str | None, fields: dict[str, Any], boxes: Any, right: float) -> None:
    ep = boxed_episode("q", [INITIAL], [])
    table = with_abstain([ep], [gold])
    r = run(table, [prediction("q", boxes, **fields)])
    value = inst(r, "q", "abstention")
    assert (math.isnan(value) and math.isnan(right)) or value == right


def test_a_missing_instance_fails_abstention() -> None:
    eps = [boxed_episode("q", [INITIAL], []), boxed_episode("r", [INITIAL], [])]
    r = run(with_abstain(eps, ["no action", "not feasible"]),
            [prediction("q", INITIAL, abstain="no action")])
    assert inst(r, "q", "abstention") == 1.0 and inst(r, "r", "abstention") == 0.0
    assert r.value("abstention") == 0.5 and r.counts["abstained"] == 1


def test_scorer_v1_gives_its_own_table(stacked: Episode) -> None:
    preds = [prediction("stack", EXTRA, program=[("top", 1, 0)], pick=[110.0, 110.0])]
    v1 = run([stacked], preds, scorer="scorer-v1")
    v2 = run([stacked], preds)
    assert v1.scorer == "scorer-v1" and v2.scorer == "scorer-v2"
    assert list(v1.summary.index) == [m.name for m in METRICS]
    assert not V2_ONLY & set(v1.per_instance.columns)
    assert set(v2.summary.index) == {m.name for m in METRICS_V2}
    for m in v1.summary.index:  # every v1 figure has the same value under v2
        a, b = v1.value(m), v2.value(m)
        assert (math.isnan(a) and math.isnan(b)) or a == b, m
    assert "success strict" not in v1.paper_table().columns
    assert v2.paper_table().loc["overall", "success strict"] == 0.0
    with pytest.raises(InvalidArgument, match="did you mean 'scorer-v2'"):
        run([stacked], preds, scorer="scorer-v3")


def test_compare_has_the_new_figures(stacked: Episode) -> None:
    a = parse_predictions(HEADER, [prediction("stack", STACKED, program=[("top", 1, 0)])])
    b = parse_predictions(HEADER, [prediction("stack", EXTRA, program=[("top", 1, 0)])])
    c = compare(a, b, [stacked], split=SPLIT, n_boot=0, n_perm=10)
    assert c.scorer == "scorer-v2"
    assert c.table.at["success_strict", "diff"] == 1.0 and c.table.at["success", "diff"] == 0
    c1 = compare(a, b, [stacked], split=SPLIT, n_boot=0, n_perm=10, scorer="scorer-v1")
    assert c1.scorer == "scorer-v1" and not V2_ONLY & set(c1.table.index)


# -- the abstain field ---------------------------------------------------------------------
def _preds_with_abstain() -> list[Prediction]:
    return [
        prediction("a", INITIAL, abstain="no action"),
        prediction("b", INITIAL, abstain="not feasible", program=[], positions=np.zeros((3, 3))),
        prediction("c", STACKED, program=[("top", 1, 0)], pick=[110.0, 110.0]),
        prediction("d", INITIAL),
    ]


@pytest.mark.parametrize("suffix", [".jsonl", ".jsonl.gz", ".parquet"])
def test_bulk_and_line_by_line_read_abstain_alike(tmp_path: Path, suffix: str) -> None:
    if suffix == ".parquet":
        pytest.importorskip("pyarrow")
    path = write_submission(tmp_path / f"p{suffix}", HEADER, _preds_with_abstain())
    sub = read_submission(path)
    assert sub.abstain is not None and sub.abstain.tolist() == [1, 2, 0, 0]
    assert sub.header.scorer == "scorer-v2" and sub.header.format_version == "1.1.0"
    if suffix == ".jsonl":
        assert_same(bulk(path), line_by_line(path))
        memory = parse_predictions(HEADER, _preds_with_abstain())
        assert memory.abstain is not None and memory.abstain.tolist() == [1, 2, 0, 0]


def test_a_file_without_abstain_is_written_as_before(tmp_path: Path) -> None:
    path = write_submission(tmp_path / "p.jsonl", HEADER, [prediction("a", INITIAL)])
    header = json.loads(path.read_text().splitlines()[0])["header"]
    assert header["scorer"] == "scorer-v1" and header["format_version"] == "1.0.0"
    assert "abstain" not in path.read_text().splitlines()[1]
    sub = read_submission(path)
    assert sub.abstain is not None and sub.abstain.tolist() == [0]
    assert_same(bulk(path), line_by_line(path))


def test_the_protocol_follows_the_header_for_abstain(tmp_path: Path) -> None:
    header = SubmissionHeader(split=SPLIT, extra={"protocol": {"scorer": "scorer-v1"}})
    path = write_submission(tmp_path / "p.jsonl", header,
                            [prediction("a", INITIAL, abstain="no action")])
    written = json.loads(path.read_text().splitlines()[0])["header"]
    assert written["scorer"] == written["protocol"]["scorer"] == "scorer-v2"


HEADER_LINE = json.dumps({"header": {"format": "nsrmp-bench-predictions",
                                     "format_version": "1.1.0", "split": SPLIT,
                                     "scorer": "scorer-v2"}})
BOXES = json.dumps(INITIAL)


@pytest.mark.parametrize(("line", "said"), [
    (f'{{"id": "q", "boxes": {BOXES}, "abstain": "no_action"}}',
     ["'no_action'", "did you mean 'no action'?"]),
    (f'{{"id": "q", "boxes": {BOXES}, "abstain": true}}', ["'abstain' is True", "not feasible"]),
    (f'{{"id": "q", "boxes": {BOXES}, "abstain": "no action", "program": [["top", 1, 0]]}}',
     ["program of 1 step(s)"]),
    (f'{{"id": "q", "boxes": {BOXES}, "abstain": "not feasible", "pick": [1, 2]}}',
     ["['pick']", "trace of actions"]),
    (f'{{"id": "q", "boxes": {BOXES}, "abstain": "no action", "step_boxes": [{BOXES}]}}',
     ["['step_boxes']"]),
])
def test_bad_abstentions_are_refused_naming_the_line(
        tmp_path: Path, line: str, said: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "episodes.jsonl"
    data.write_text("".join(json.dumps(boxed_episode(i, [INITIAL], []).symbolic.to_dict()) + "\n"
                            for i in ("p", "q")))  # as many instances as the file's lines
    bad = tmp_path / "bad.jsonl"
    good = json.dumps({"id": "p", "boxes": INITIAL})
    bad.write_text(f"{HEADER_LINE}\n{good}\n{line}\n")
    assert read_submission_fails(bad)
    assert main(["score", str(bad), "--data", str(data), "--split", SPLIT]) == 2
    err = capsys.readouterr().err
    assert "line 3" in err and "Traceback" not in err
    for text in said:
        assert text in err


def read_submission_fails(path: Path) -> bool:
    with pytest.raises(SubmissionError, match="line 3"):
        read_submission(path)
    return True


def test_score_cli_says_the_scorer(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "episodes.jsonl"
    data.write_text(json.dumps(boxed_episode("q", [INITIAL], []).symbolic.to_dict()) + "\n")
    pred = write_submission(tmp_path / "p.jsonl", HEADER, [prediction("q", INITIAL)])
    for scorer in ("scorer-v1", "scorer-v2"):
        out = tmp_path / f"{scorer}.json"
        assert main(["score", str(pred), "--data", str(data), "--split", SPLIT, "--n-boot",
                     "0", "--scorer", scorer, "--json", str(out)]) == 0
        report = json.loads(out.read_text())
        assert report["scorer"] == scorer
        assert ("kept_still" in report["summary"]) == (scorer == "scorer-v2")
        printed = capsys.readouterr().out
        assert scorer in printed and ("strict success" in printed) == (scorer == "scorer-v2")


# -- boards --------------------------------------------------------------------------------
def test_a_board_says_its_scorer_and_shows_strict_success() -> None:
    from nsrmp_bench.leaderboard import COLUMNS, render_markdown

    row = {"model": "m", "kind": "baseline", "n": 3,
           "metrics": {m: (0.5, 0.4, 0.6) for m in COLUMNS}}
    text = render_markdown("unit-v1/test", [row])
    assert "Scored with scorer-v2" in text and "success_strict | kept_still" in text
    assert "0.500 [0.400, 0.600]" in text
    assert "Scored with scorer-v1." in render_markdown("unit-v1/test", [row], "scorer-v1")


def test_a_robustness_table_shows_strict_success_where_it_has_it() -> None:
    from nsrmp_bench.results.robustness_table import KindRow, Suite, suite_from_dict

    old = KindRow("m", "typo", False, 3, 4, 0.5, 0.4, 0.6, 0.7, -0.2, -0.3, -0.1, 0.01,
                  0.5, 0.6, 0.4)
    suite = Suite("unit-v1/test", 0, "0" * 64, (old,))
    assert "strict success" not in suite.table()[0]
    assert "success_strict" not in suite.to_dict()["rows"][0]  # written as before
    new = dataclasses.replace(old, success_strict=0.3, kept_still=0.9,
                              clean_success_strict=0.35, clean_kept_still=0.95)
    suite = Suite("unit-v1/test", 0, "0" * 64, (new,))
    head, rows = suite.table()
    assert head[:4] == ["model", "IoU-M", "strict success", "kept still"]
    assert rows[0][2:4] == ["0.350", "0.950"]
    assert suite_from_dict(suite.to_dict(), "x") == suite
