"""The reader of sentence structure (nsrm-v4, nmn-v4): each behaviour on real sentences.

Pure text, no torch: what the reader makes of an instruction before a model reads it."""

from __future__ import annotations

import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.language.structure import (
    NO_ACTION,
    NOT_FEASIBLE,
    plain_phrases,
    read_structure,
)


def test_taking_then_putting_it_is_one_step() -> None:
    s = read_structure("Pick up the red cube. Put it on the blue dice.")
    assert s.abstain is None and s.steps == 1
    assert s.text == "pick up the red cube and put it on the blue dice ."


def test_a_constraint_is_no_step() -> None:
    for said in ("Put the red cube on the blue dice, and leave the green lego where it is.",
                 "Put the red cube on the blue dice without touching the green lego.",
                 "Put the red cube on the blue dice, but do not move the green lego.",
                 "Put the red cube on the blue dice and keep the green lego in place."):
        s = read_structure(said)
        assert s.abstain is None and s.steps == 1, said
        assert s.text == "put the red cube on the blue dice .", said
        assert "green lego" in s.constraints[0]


def test_a_prohibition_alone_asks_for_no_action() -> None:
    for said in ("Don't move the red lego.", "Do not touch the red lego.",
                 "Leave the red lego alone.", "Please don’t put the red lego anywhere."):
        assert read_structure(said).abstain == NO_ACTION, said


def test_a_question_or_a_remark_asks_for_no_action() -> None:
    for said in ("Is the red lego behind the white dice?", "Where is the red lego?",
                 "The red lego is to the left of the white dice."):
        assert read_structure(said).abstain == NO_ACTION, said
    # a request put as a question is a request
    s = read_structure("Could you put the red cube on the blue dice?")
    assert s.abstain is None and s.steps == 1


def test_a_self_correction_replaces_what_it_corrects() -> None:
    s = read_structure("Put the red cube on the blue cube, no, on the green one.")
    assert s.text == "put the red cube on the green cube ."
    s = read_structure("Set the red lego on the right side of the cyan dice, no, I mean the "
                       "white one.")
    assert s.text == "set the red lego on the right side of the white dice ."


def test_ellipsis_refers_back() -> None:
    s = read_structure("Put the red cube on the blue dice, then the green one on top of it.")
    assert s.steps == 2 and s.base_previous == (1,)
    assert s.text.endswith("then put the green cube on top of it .")
    s = read_structure("Put the red cube on the blue dice. Then the green one on it.")
    assert s.steps == 2 and s.base_previous == (1,)


@pytest.mark.parametrize(("said", "side", "rank", "role"), [
    ("Put the leftmost cube on the blue dice.", "left", 1, "subject"),
    ("Put the red cube on the second dice from the right.", "right", 2, "base"),
    ("Move the lego nearest to the robot onto the green cube.", "behind", 1, "subject"),
    ("Move the red dice left of the thing closest to you.", "front", 1, "base"),
])
def test_superlatives_are_extreme(said: str, side: str, rank: int, role: str) -> None:
    s = read_structure(said)
    (e,) = s.extremes
    assert (e.side, e.rank, e.role, e.step) == (side, rank, role, 0)
    assert "most" not in s.text and "second" not in s.text


def test_a_colour_or_shape_the_world_lacks_is_not_feasible() -> None:
    for said in ("Put the grey cube on the green lego.", "Put the red pyramid on the dice.",
                 "Put the blue cube on the orange ball."):
        assert read_structure(said).abstain == NOT_FEASIBLE, said


def test_unknown_words_stay_in_the_text() -> None:
    s = read_structure("Put the zorbly cube on the blue dice, and leave the lego alone.")
    assert "zorbly" in s.text and "zorbly" in s.unknown


def test_plain_phrases_are_the_ones_a_model_can_check() -> None:
    def got(said: str) -> list[tuple[str | None, str | None]]:
        return [(p.colour, p.shape) for p in plain_phrases(said)]

    assert got("Put the block which is a lego and is magenta on top of the red cube.") == [
        ("magenta", "lego"), ("red", "cube")]
    # "the red cube behind the dice" refers through the dice; "the dice" is the anchor
    # of a relation, followed by the destination: neither is checked alone
    assert got("Put the red cube behind the dice on the green lego.") == [("green", "lego")]
    assert got("Put the leftmost cube on the only dice.") == []


def test_plain_instructions_are_left_as_they_are() -> None:
    said = "Put the red cube on top of the blue dice, then put the green lego to its left."
    s = read_structure(said)
    assert s.text == said and not s.changed and s.steps == 2


def test_ten_steps_are_refused() -> None:
    said = ", then ".join(["put the red cube on the blue dice"] * 10) + "."
    with pytest.raises(InvalidArgument, match="at most 7"):
        read_structure(said)
