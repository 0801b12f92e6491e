"""The one check every instruction passes where it enters: a model's ``predict``, the
``predict`` and ``rollout`` verbs, and the closed-loop environment.

An instruction is a ``str`` that holds something other than whitespace, of at most
:data:`MAX_INSTRUCTION_CHARS` characters. Anything else is refused with the value, what
was expected and the fix; nothing is turned into text silently (``str(None)`` would read
as the instruction "None"). An instruction that asks for no action ("Go ahead.") is
well formed: the models of kind program that say so (``nsrm-v3``, ``nmn-v3``) predict the
empty program for it, and nothing moves.
"""

from __future__ import annotations

from typing import Final

from nsrmp_bench.errors import InvalidArgument

__all__ = ["MAX_INSTRUCTION_CHARS", "check_instruction"]

MAX_INSTRUCTION_CHARS: Final = 2000
"""The longest instruction accepted (the longest official one, seven steps in compound
phrasing on steps-v2/test, has 1,144 characters)."""


def check_instruction(value: object, where: str = "the instruction") -> str:
    """``value`` if it is a well-formed instruction, else :class:`InvalidArgument`."""
    if isinstance(value, bytes | bytearray):
        msg = (f"{where} is bytes ({bytes(value)[:40]!r}); expected text (str): decode it "
               "first, e.g. value.decode('utf-8')")
        raise InvalidArgument(msg)
    if not isinstance(value, str):
        msg = (f"{where} is {value!r} of type {type(value).__name__}; expected the "
               "instruction as a non-empty str (a model reads what a person says: pass "
               "the text)")
        raise InvalidArgument(msg)
    if not value.strip():
        msg = (f"{where} is {value!r}: empty or only whitespace; expected what to do, "
               "e.g. 'put the red cube on top of the blue dice' (to move nothing, predict "
               "nothing: the noop baseline)")
        raise InvalidArgument(msg)
    if len(value) > MAX_INSTRUCTION_CHARS:
        msg = (f"{where} has {len(value)} characters ({value[:40]!r}...); expected at most "
               f"{MAX_INSTRUCTION_CHARS}: give fewer steps per instruction")
        raise InvalidArgument(msg)
    return value
