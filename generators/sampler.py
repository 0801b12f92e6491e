"""Sampling whole symbolic episodes: scene, program, instruction, from a seed.

Instance ``index`` of a spec with entropy ``e`` is a pure function of (config, e, index):
attempt ``a`` draws everything from ``SeedSequence(e, spawn_key=(index, a))``, and a
rejected attempt (no valid program, a failed constraint, a physics rejection downstream)
moves on to attempt ``a + 1``, up to a bounded number of attempts.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeVar

from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.episode import SeedInfo, SymbolicEpisode
from nsrmp_bench.errors import GenerationError
from nsrmp_bench.generators.instructions import render_instruction
from nsrmp_bench.generators.phenomena import write_phenomenon
from nsrmp_bench.generators.program_sampler import sample_program
from nsrmp_bench.generators.scene_sampler import sample_scene
from nsrmp_bench.generators.templates import load_language

if TYPE_CHECKING:
    from nsrmp_bench.generators.program_sampler import ProgramSample
    from nsrmp_bench.scene import SceneObject

__all__ = [
    "GENERATOR_ID", "AttemptLog", "EpisodeConfig", "first_valid", "sample_episode",
    "sample_symbolic",
]

GENERATOR_ID = "symbolic-v1"
T = TypeVar("T")


def _referenced_pairs(sample: ProgramSample,
                      objects: Sequence[SceneObject]) -> set[tuple[str, str]]:
    out: set[tuple[str, str]] = set()
    for step in sample.grounded:
        for i in (step.subject, step.reference):
            out.add((objects[i].shape, objects[i].colour))
    return out


def sample_symbolic(config: EpisodeConfig, seed: SeedInfo, episode_id: str) -> SymbolicEpisode:
    """One attempt: raises GenerationError when this seed yields no valid episode."""
    rng = seed.generator()
    scene = sample_scene(
        rng, config.objects, pairs=config.pairs, duplicates=config.forced_duplicates
    )
    if config.phenomenon:
        written = write_phenomenon(rng, config, scene)
        return SymbolicEpisode(
            id=episode_id, generator=GENERATOR_ID, seed=seed, scene=scene,
            program=written.sample.program, grounded=written.sample.grounded,
            instruction=written.instruction, states=written.sample.states,
            references=written.sample.labels, phenomenon=config.phenomenon,
            abstain=written.abstain,
        )
    sample = sample_program(rng, scene, config.steps, relational=config.relational)
    if config.required_pairs and not (
        _referenced_pairs(sample, scene.objects) & set(config.required_pairs)
    ):
        msg = "no step moves or targets an object of a required (shape, colour) pair"
        raise GenerationError(msg)
    instruction = render_instruction(
        rng, load_language(), scene.objects, sample,
        phrasing=config.phrasing, held_out=config.held_out,
    )
    return SymbolicEpisode(
        id=episode_id,
        generator=GENERATOR_ID,
        seed=seed,
        scene=scene,
        program=sample.program,
        grounded=sample.grounded,
        instruction=instruction,
        states=sample.states,
        references=sample.labels,
    )


@dataclass
class AttemptLog:
    """How many attempts were made, and why the rejected ones were rejected."""

    reasons: Counter[str] = field(default_factory=Counter)
    attempts: int = 0
    episodes: int = 0

    def merge(self, other: AttemptLog) -> None:
        """Add another log's counts (e.g. a worker's)."""
        self.reasons.update(other.reasons)
        self.attempts += other.attempts
        self.episodes += other.episodes


def _reason(exc: GenerationError) -> str:
    code = getattr(exc, "reason", None)  # physics rejections carry a reason code
    return f"physics:{code}" if code else "symbolic"


def first_valid(
    entropy: int,
    index: int,
    attempt_fn: Callable[[SeedInfo], T],
    *,
    max_attempts: int = 64,
    log: AttemptLog | None = None,
    what: str = "",
) -> T:
    """``attempt_fn(SeedInfo(entropy, index, a))`` for the first ``a`` that raises no
    GenerationError; GenerationError naming the last problem past ``max_attempts``."""
    last: GenerationError | None = None
    for attempt in range(max_attempts):
        if log is not None:
            log.attempts += 1
        try:
            result = attempt_fn(SeedInfo(entropy, index, attempt))
        except GenerationError as exc:
            last = exc
            if log is not None:
                log.reasons[_reason(exc)] += 1
            continue
        if log is not None:
            log.episodes += 1
        return result
    msg = (
        f"instance {index}: no valid episode in {max_attempts} attempts{what}; "
        f"last problem: {last}. Relax the config (fewer steps or objects, relational='any')"
    )
    raise GenerationError(msg)


def sample_episode(
    config: EpisodeConfig,
    entropy: int,
    index: int,
    episode_id: str,
    *,
    max_attempts: int = 64,
    log: AttemptLog | None = None,
) -> SymbolicEpisode:
    """The first valid symbolic attempt for instance ``index``."""
    return first_valid(
        entropy, index, lambda seed: sample_symbolic(config, seed, episode_id),
        max_attempts=max_attempts, log=log, what=f" for {config}",
    )
