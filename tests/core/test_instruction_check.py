"""Instructions are checked where they enter; nothing is turned into text silently."""

from __future__ import annotations

import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.instruction_check import MAX_INSTRUCTION_CHARS, check_instruction


@pytest.mark.parametrize(("value", "match"), [
    (None, "None of type NoneType"),
    (7, "7 of type int"),
    (b"put it", "bytes .* decode it"),
    ("", "empty or only whitespace"),
    (" \n\t", "empty or only whitespace"),
    ("x" * (MAX_INSTRUCTION_CHARS + 1), f"at most {MAX_INSTRUCTION_CHARS}"),
])
def test_a_bad_instruction_is_named_with_its_fix(value: object, match: str) -> None:
    with pytest.raises(InvalidArgument, match=match):
        check_instruction(value, "the instruction of episode 'e1'")


def test_a_good_instruction_passes_unchanged() -> None:
    assert check_instruction("Go ahead.") == "Go ahead."
