"""Fuzzing malformed predictions files: no traceback escapes (only SubmissionError), and
when a file is accepted every one of its lines is accounted for (none dropped silently)."""

from __future__ import annotations

import copy
import json
import tempfile
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from scoring_factory import HEADER, SPLIT, boxed_episode

from nsrmp_bench.errors import SubmissionError
from nsrmp_bench.scoring import load_schema, score
from nsrmp_bench.scoring.gold import GoldTable
from nsrmp_bench.scoring.validate import parse_submission

INITIAL = [[100, 100, 120, 120], [200, 100, 220, 120], [50, 50, 70, 70], [10, 200, 30, 220]]
FINAL = [[100, 100, 120, 120], [100, 85, 120, 105], [50, 50, 70, 70], [10, 200, 30, 220]]

GOLD = GoldTable.from_episodes(
    [
        boxed_episode("e0", [INITIAL[:3], FINAL[:3]], [("top", 1, 0)]),
        boxed_episode("e1", [INITIAL[:3], FINAL[:3], FINAL[:3]], [("top", 1, 0), ("left", 2, 1)]),
        boxed_episode("e2", [INITIAL, FINAL], [("right", 3, 2)]),
    ],
    split=SPLIT,
)


def valid_record(eid: str) -> dict[str, Any]:
    g = GOLD.index[eid]
    n = int(GOLD.n_objects[g])
    s = int(GOLD.n_steps[g])
    return {
        "id": eid,
        "boxes": [list(b) for b in FINAL[:n]],
        "step_boxes": [[list(b) for b in FINAL[:n]] for _ in range(s)],
        "program": [["top", 1, 0]] * s,
        "pick": [110.0, 110.0],
        "place": [110.0, 95.0],
        "positions": [[0.0, 0.0, 0.6]] * n,
    }


json_values = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=5),
    lambda children: st.lists(children, max_size=5)
    | st.dictionaries(st.text(max_size=5), children, max_size=3),
    max_leaves=8,
)
bad_numbers = st.sampled_from(
    [float("nan"), float("inf"), -float("inf"), 1e300, -5.0, 10**40, "3", None, True, [1], {}]
)
FIELDS = ["id", "boxes", "step_boxes", "program", "pick", "place", "positions"]


IDS = ["e0", "e1", "e2", "stray", "stray2"]
MUTATIONS = ["drop", "replace", "number", "swap", "extra", "value"]


@st.composite
def mutated_record(draw: st.DrawFn, eid: str | None = None, mutate: float = 1.0) -> Any:
    eid = eid if eid is not None else draw(st.sampled_from(IDS))
    rec: Any = valid_record(eid if eid in GOLD.index else "e0")
    rec["id"] = eid
    # Keep some records valid, and some optional fields absent.
    for field in ("step_boxes", "program", "pick", "place", "positions"):
        if draw(st.booleans()):
            rec.pop(field)
    mutated = draw(st.floats(0, 1)) < mutate
    kind = draw(st.sampled_from(MUTATIONS)) if mutated else "keep"
    field = draw(st.sampled_from(FIELDS))
    if kind == "drop":
        rec.pop(field, None)
    elif kind == "replace":
        rec[field] = draw(json_values)
    elif kind == "number":
        target = rec["boxes"][draw(st.integers(0, len(rec["boxes"]) - 1))]
        target[draw(st.integers(0, 3))] = draw(bad_numbers)
    elif kind == "swap":
        box = rec["boxes"][0]
        box[0], box[2] = box[2] + 1, box[0]
    elif kind == "extra":
        rec[draw(st.text(min_size=1, max_size=6))] = draw(json_values)
    elif kind == "value":
        rec = draw(json_values)
    return rec


def _text(value: Any) -> str:
    return json.dumps(value)  # NaN / Infinity written as the tokens Python reads back


@st.composite
def submission_text(draw: st.DrawFn) -> tuple[str, int]:
    """A file's text and how many data lines (after the header) it has."""
    header: Any = {"header": HEADER.to_dict()}
    hkind = draw(st.sampled_from(["keep"] * 12 + ["drop", "split", "scorer", "version", "junk"]))
    if hkind == "split":
        header["header"]["split"] = "paper-v2"
    elif hkind == "scorer":
        header["header"]["scorer"] = "scorer-v2"
    elif hkind == "version":
        header["header"]["format_version"] = draw(st.sampled_from(["2.0.0", "x", ""]))
    elif hkind == "junk":
        header = draw(json_values)
    ids = draw(st.lists(st.sampled_from(IDS[:3]), unique=True, min_size=1, max_size=3))
    if draw(st.integers(0, 3)) == 0:
        ids.insert(draw(st.integers(0, len(ids))), draw(st.sampled_from(IDS[3:])))
    if draw(st.integers(0, 9)) == 0:
        ids.append(ids[0])  # a duplicate now and then
    records = [draw(mutated_record(eid, mutate=0.15)) for eid in ids]
    lines = [] if hkind == "drop" else [_text(header)]
    for rec in records:
        text = _text(rec)
        cut = draw(st.sampled_from(["none"] * 20 + ["truncate", "garbage"]))
        if cut == "truncate":
            text = text[: draw(st.integers(0, max(0, len(text) - 1)))]
        elif cut == "garbage":
            text = draw(st.text(min_size=1, max_size=20))
        lines.append(text)
    return "\n".join(lines) + "\n", len([line for line in lines[1:] if line.strip()])


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(submission_text(), st.sampled_from(["error", "warn"]))
def test_malformed_files_raise_only_submission_errors(case: tuple[str, int], mode: str) -> None:
    text, _ = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "p.jsonl"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        try:
            result = score(path, GOLD, n_boot=0, unknown_ids=mode)
        except SubmissionError as exc:
            assert str(exc)  # a message, never empty
            event("refused")
            return
    c = result.counts
    event(f"accepted with {min(c['lines'], 3)}+ lines")
    # Every data line became a prediction or a counted, ignored unknown id.
    assert c["lines"] == c["predicted"] + c["unknown_ids_ignored"]
    assert c["missing"] == len(GOLD) - c["predicted"]
    assert len(result.per_instance) == len(GOLD)
    assert int(result.per_instance["present"].sum()) == c["predicted"]
    data_lines = [line for line in text.splitlines()[1:] if line.strip()]
    assert c["lines"] == len(data_lines)


SCHEMA = jsonschema.Draft202012Validator(load_schema())


@settings(max_examples=300, deadline=None)
@given(mutated_record())
def test_what_the_schema_rejects_the_scorer_rejects(record: Any) -> None:
    if isinstance(record, dict) and record.get("id") == "stray":
        record["id"] = "e0"
    schema_ok = SCHEMA.is_valid(copy.deepcopy(record)) and not (
        isinstance(record, dict) and "header" in record
    )
    try:
        parse_submission({"header": HEADER.to_dict()}, [record], source="<fuzz>")
        ours_ok = True
    except SubmissionError:
        ours_ok = False
    if not schema_ok:
        assert not ours_ok, f"the schema rejects {record!r} but the scorer accepted it"


@pytest.mark.parametrize("eid", ["e0", "e1", "e2"])
def test_valid_records_pass_both(eid: str) -> None:
    rec = valid_record(eid)
    assert SCHEMA.is_valid(rec)
    assert SCHEMA.is_valid({"header": HEADER.to_dict()})
    parse_submission({"header": HEADER.to_dict()}, [rec], source="<ok>")
