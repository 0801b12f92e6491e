"""Instances forked from a primed template world: the same bytes as made in-process."""

from __future__ import annotations

import os

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.generators.generate import make_episode
from nsrmp_bench.generators.world.template import can_fork, run_forked
from nsrmp_bench.generators.world.world import World
from nsrmp_bench.split_specs import load_split
from nsrmp_bench.storage.hashing import episode_hash

pytestmark = [pytest.mark.sim,
              pytest.mark.skipif(not can_fork(), reason="needs os.fork (POSIX)")]


def test_forked_instances_are_the_in_process_bytes() -> None:
    spec = load_split("smoke-v2")
    with World() as here, World() as template:
        expected = [episode_hash(make_episode(spec, "test", i, here)) for i in range(4)]
        scenery = None
        for i in reversed(range(4)):  # another order than in-process
            episode = run_forked(template, lambda i=i: make_episode(spec, "test", i, template))
            assert episode_hash(episode) == expected[i]
            # the template's own world is never touched: only the scenery, still primed
            scenery = template.body_count() if scenery is None else scenery
            assert template.body_count() == scenery
            assert template.primed


def test_a_childs_exception_is_raised_in_the_parent() -> None:
    def fail() -> None:
        msg = "refused in the child"
        raise InvalidArgument(msg)

    with World() as world:
        with pytest.raises(InvalidArgument, match="refused in the child"):
            run_forked(world, fail)
        assert run_forked(world, os.getpid) != os.getpid()
