"""The non-learned baselines by id, and running one over a split into a predictions file.

Each is registered in the one registry of predictors (:mod:`nsrmp_bench.predictors`) as
kind ``baseline``.

Each baseline maps (episode, Generator) to a :class:`Prediction`; the Generator is derived
per instance from (seed, instance id), so an instance's prediction does not depend on
which other instances are predicted or in what order.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nsrmp_bench.baselines.noop import noop_prediction
from nsrmp_bench.baselines.oracle import oracle_prediction
from nsrmp_bench.baselines.random_steps import random_prediction
from nsrmp_bench.episode import Episode, SymbolicEpisode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.predictors import Kind, register_predictor
from nsrmp_bench.scoring.protocol_fields import GOLD_BOXES, ProtocolFields
from nsrmp_bench.scoring.submission import Prediction, SubmissionHeader, write_submission
from nsrmp_bench.scoring.version import WRITTEN_SCORER_ID
from nsrmp_bench.versioned_ids import resolve_id

__all__ = ["BASELINES", "Baseline", "get_baseline", "predict", "run_baseline"]

PredictFn = Callable[[Episode, np.random.Generator], Prediction]


@dataclass(frozen=True)
class Baseline:
    """A registered baseline: id, what it does, and its per-episode prediction function."""

    id: str
    description: str
    predict: PredictFn
    reads: str
    """What it reads of an episode (its model card's "inputs"); no baseline is trained."""
    supervision: str = "none"
    """Its protocol's ``supervision``: the gold it reads, as no baseline learns."""
    seeded: bool = False
    """Whether its predictions depend on the seed (then the protocol's ``seeds``)."""

    @property
    def kind(self) -> Kind:
        """Every baseline's kind (:mod:`nsrmp_bench.predictors`)."""
        return Kind.BASELINE

    @property
    def label(self) -> str:
        """Nothing is said beside a baseline's id."""
        return ""

    def protocol(self, seed: int, manifest_root_hash: str) -> ProtocolFields:
        """Its protocol fields on the part with root hash ``manifest_root_hash``."""
        return ProtocolFields(
            supervision=self.supervision, boxes=GOLD_BOXES, training_parts=(),
            seeds=(seed,) if self.seeded else (), scorer=WRITTEN_SCORER_ID,
            manifest_root_hash=manifest_root_hash,
        )


BASELINES: dict[str, Baseline] = {
    b.id: b
    for b in (
        Baseline("oracle-v1", "gold program executed symbolically (upper bound)",
                 oracle_prediction, "the gold grounded program, the initial poses and the "
                 "camera (gold targets: an upper bound, not a model)",
                 supervision="none (not learned); reads the gold program: an upper bound"),
        Baseline("noop-v1", "nothing moves: final boxes = initial boxes (floor)",
                 noop_prediction, "the initial boxes", supervision="none (not learned)"),
        Baseline("random-v1", "a random legal step per gold step", random_prediction,
                 "the initial poses, the camera and the number of gold steps",
                 supervision="none (not learned); reads the number of gold steps", seeded=True),
    )
}
"""Baseline id (``name-vN``) -> baseline; each is a predictor of kind ``baseline`` too."""

for _baseline in BASELINES.values():
    register_predictor(_baseline)


def get_baseline(name: str) -> Baseline:
    """The baseline ``name`` (an id, or a bare name meaning its latest version)."""
    return BASELINES[resolve_id(name, BASELINES, "baseline")]


def predict(
    baseline: Baseline, episodes: Iterable[Episode | SymbolicEpisode], seed: int = 0
) -> Iterator[Prediction]:
    """The baseline's predictions, one per episode, in order."""
    if not isinstance(seed, int) or seed < 0:
        msg = f"seed must be a non-negative integer, got {seed!r}"
        raise InvalidArgument(msg)
    for item in episodes:
        ep = item if isinstance(item, Episode) else Episode(item)
        key = int.from_bytes(hashlib.sha256(ep.id.encode("utf-8")).digest()[:8], "little")
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(key,)))
        yield baseline.predict(ep, rng)


def run_baseline(
    name: str,
    episodes: Iterable[Episode | SymbolicEpisode],
    out: str | Path,
    *,
    split: str,
    seed: int = 0,
    manifest_root_hash: str | None = None,
) -> Path:
    """Write baseline ``name``'s predictions for ``episodes`` (split ``split``) to ``out``;
    with ``manifest_root_hash`` (of the part the episodes are) the header states the
    protocol."""
    baseline = get_baseline(name)
    extra: dict[str, object] = {"seed": seed}
    if manifest_root_hash is not None:
        extra["protocol"] = baseline.protocol(seed, manifest_root_hash).to_dict()
    header = SubmissionHeader(split=split, model=baseline.id, extra=extra)
    return write_submission(out, header, predict(baseline, episodes, seed))
