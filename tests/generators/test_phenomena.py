"""The semantics split's phenomena: gold programs, decisions and phrasings, over seeds."""

from __future__ import annotations

import json
import re
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.dsl.executor import execute, resolve
from nsrmp_bench.dsl.program import Node, Program
from nsrmp_bench.dsl.relations import ranked
from nsrmp_bench.episode import SymbolicEpisode
from nsrmp_bench.errors import AmbiguousReference, GenerationError, InvalidArgument
from nsrmp_bench.generators import phenomena
from nsrmp_bench.generators.sampler import sample_episode
from nsrmp_bench.generators.templates import load_phenomena
from nsrmp_bench.scene import Pose
from nsrmp_bench.split_specs import load_split, load_split_file
from nsrmp_bench.vocabulary import COLOURS, PHENOMENA, SHAPES

NO_ACTION = {"prohibition": "no action", "question": "no action",
             "absent": "not feasible", "ambiguous": "not feasible"}


def _episode(phenomenon: str, seed: int, *, objects: int = 4, steps: int = 1,
             relational: str = "none", wording: str = "seen") -> SymbolicEpisode:
    config = EpisodeConfig(objects=objects, steps=steps, relational=relational,
                           phenomenon=phenomenon, phenomenon_phrasing=wording)
    return sample_episode(config, seed, seed % 89, "sem", max_attempts=200)


def test_every_phenomenon_has_a_writer_and_phrasings() -> None:
    assert set(phenomena._WRITERS) == set(PHENOMENA)
    data = load_phenomena()
    for name in PHENOMENA:
        if name != "ambiguous":
            assert data[name]["seen"] and data[name]["held_out"]


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(phenomenon=st.sampled_from(PHENOMENA), seed=st.integers(0, 2**32 - 1),
       objects=st.integers(3, 6), steps=st.integers(1, 2),
       relational=st.sampled_from(["none", "any"]),
       wording=st.sampled_from(["seen", "held_out"]))
def test_phenomenon_episode_is_consistent(phenomenon: str, seed: int, objects: int,
                                          steps: int, relational: str, wording: str) -> None:
    ep = _episode(phenomenon, seed, objects=objects, steps=steps, relational=relational,
                  wording=wording)
    assert ep.phenomenon == phenomenon
    assert ep.categories()["phenomenon"] == phenomenon
    assert not re.search(r"[{}<>]", ep.instruction.text)
    assert ep.instruction.held_out_template == (wording == "held_out")
    assert SymbolicEpisode.from_dict(ep.to_dict()) == ep
    run = execute(ep.program, ep.scene)
    assert run.grounded == ep.grounded and run.states == ep.states
    if phenomenon in NO_ACTION:
        assert ep.abstain == NO_ACTION[phenomenon]
        assert ep.num_steps == 0 and ep.program == Program((Node("idle"),))
        return
    assert ep.abstain == ""
    assert ep.num_steps == (2 if phenomenon == "ellipsis" else steps)
    for k, node_index in enumerate(ep.program.steps):  # every reference resolves
        node = ep.program.nodes[node_index]
        assert resolve(ep.program, node.inputs[1], ep.scene, ep.states[k]) == ep.grounded[k].subject
        assert resolve(ep.program, node.inputs[2], ep.scene, ep.states[k]) == ep.grounded[k].reference
    if phenomenon == "superlative":
        assert any(n.op == "extreme" for n in ep.program.nodes)


def test_negation_names_an_object_the_program_leaves_still() -> None:
    ep = _episode("negation", 11)
    used = {i for s in ep.grounded for i in (s.subject, s.reference)}
    still = [o for i, o in enumerate(ep.scene.objects) if i not in used]
    assert any(o.colour in ep.instruction.text for o in still)


def test_absent_names_nothing_in_the_scene() -> None:
    for seed in range(12):
        ep = _episode("absent", seed)
        text = ep.instruction.text.lower()
        outside = [w for w in ("grey", "orange", "black", "ball", "cylinder") if w in text]
        present = {(o.colour, o.shape) for o in ep.scene.objects}
        assert outside or any(c in text and s in text and (c, s) not in present
                              for c in COLOURS for s in SHAPES), text


def test_held_out_phrasings_only_where_asked() -> None:
    data = load_phenomena()
    held = [t.split("{")[0].strip() for t in data["prohibition"]["held_out"] if t.split("{")[0]]
    for seed in range(10):
        text = _episode("prohibition", seed).instruction.text
        assert not any(text.startswith(h) for h in held if h), text


def test_semantics_split_is_balanced_over_phenomena() -> None:
    spec = load_split("semantics-v1")
    test = spec.part("test")
    configs = [spec.config("test", i) for i in range(test.count)]
    for field in ("phenomenon", "phenomenon_phrasing", "objects", "steps", "relational",
                  "phrasing"):  # the cell stride spreads 1,000 over 648 cells
        counts = Counter(getattr(c, field) for c in configs)
        assert max(counts.values()) - min(counts.values()) <= 2, (field, counts)
    assert set(Counter(c.phenomenon for c in configs)) == set(PHENOMENA)
    for part in ("train", "val"):
        assert {spec.config(part, i).phenomenon_phrasing
                for i in range(spec.part(part).count)} == {"seen"}


def test_old_grids_keep_their_cell_order() -> None:
    spec = load_split("paper-v2")
    config = spec.config("test", 7)
    assert config.phenomenon == "" and (config.objects, config.steps) == (3, 2)


def test_extreme_ranks_and_refuses_ties() -> None:
    def pose(x: float, y: float) -> Pose:
        return Pose((x, y, 0.65))

    state = (pose(-0.2, 0.0), pose(0.0, 0.1), pose(0.2, -0.1), pose(0.21, 0.15))
    assert ranked(state, range(4), "left", 1) == 0
    assert ranked(state, range(4), "left", 2) == 1
    assert ranked(state, range(4), "behind", 1) == 3
    assert ranked(state, range(4), "front", 1) == 2
    with pytest.raises(AmbiguousReference):
        ranked(state, range(4), "right", 1)  # 0.20 and 0.21 are not apart
    with pytest.raises(InvalidArgument):
        ranked(state, range(4), "left", 0)


def test_a_phenomenon_outside_the_vocabulary_is_refused() -> None:
    with pytest.raises(InvalidArgument, match="phenomenon='sarcasm'"):
        EpisodeConfig(phenomenon="sarcasm")
    with pytest.raises(GenerationError):
        phenomena.write_phenomenon(None, EpisodeConfig(), None)  # type: ignore[arg-type]


def test_a_cell_stride_sharing_a_factor_with_the_cells_is_refused(tmp_path: Path) -> None:
    spec = json.loads(json.dumps(load_split("semantics-v1").raw))  # a deep copy
    spec["id"] = "mysemantics-v1"
    spec["parts"]["test"]["cell_stride"] = 9  # 648 cells: 9 divides it
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec), "utf-8")
    with pytest.raises(InvalidArgument, match="cell_stride: 9 shares a factor"):
        load_split_file(path)


def test_a_program_says_the_oldest_dsl_that_reads_it() -> None:
    superlative = _episode("superlative", 3)
    assert superlative.program.dsl_version == "dsl-v2"
    assert _episode("negation", 3).program.dsl_version == "dsl-v1"
