"""``nsrmp-bench sample``: generate one episode and print it as JSON.

Example::

    nsrmp-bench sample --seed 7 --objects 12 --steps 5 --relational needed --phrasing complex

The same arguments print the same bytes, in any process.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.cli.numbers import non_negative_int
from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.vocabulary import PHRASINGS

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("--seed", type=non_negative_int, default=0,
                        help="entropy of the seed (default 0)")
    parser.add_argument("--index", type=non_negative_int, default=0,
                        help="instance index under the seed")
    parser.add_argument("--objects", type=int, default=5, help="number of objects, 3..15")
    parser.add_argument("--steps", type=int, default=1, help="number of steps, 1..7")
    parser.add_argument(
        "--relational",
        nargs="?",
        const="any",
        default="none",
        choices=("none", "any", "needed", "redundant"),
        help="use relational references (bare flag = any); "
        "'needed': attributes alone are ambiguous",
    )
    parser.add_argument("--phrasing", default="simple", choices=PHRASINGS)
    parser.add_argument("--held-out", default="exclude", choices=("exclude", "require"),
                        help="'require' uses held-out templates/synonyms (the language split)")
    parser.add_argument("--indent", type=int, default=None, help="pretty-print with this indent")
    parser.add_argument(
        "--render", type=Path, default=None, metavar="OUT",
        help="also realise it in PyBullet and write OUT/<episode id>/ (HDF5 shard + manifest)",
    )
    parser.add_argument("--executor", default="teleport", choices=("teleport", "robot"),
                        help="with --render: teleport-and-settle, or the Panda's pick-and-place")
    parser.add_argument("--width", type=int, default=320, help="with --render: image width")
    parser.add_argument("--height", type=int, default=240, help="with --render: image height")


def run(args: argparse.Namespace) -> int:
    """Print the episode's JSON to stdout."""
    from nsrmp_bench.generators import sampler

    config = EpisodeConfig(
        objects=args.objects, steps=args.steps, relational=args.relational,
        phrasing=args.phrasing, held_out=args.held_out,
    )
    episode_id = f"sample-{args.seed}-{args.index}"
    if args.render is not None:
        return _render(args, config, episode_id)
    episode = sampler.sample_episode(config, args.seed, args.index, episode_id)
    data = episode.to_dict()
    if args.indent is None:
        sys.stdout.write(canonical_json(data) + "\n")
    else:
        import json

        sys.stdout.write(json.dumps(data, indent=args.indent, sort_keys=True) + "\n")
    return 0


def _render(args: argparse.Namespace, config: EpisodeConfig, episode_id: str) -> int:
    """Realise the episode (next attempt on a physics rejection) and store it."""
    from nsrmp_bench.generators import generate as gen
    from nsrmp_bench.generators.world.world import World
    from nsrmp_bench.geometry.default_camera import official_camera
    from nsrmp_bench.storage.resume import write_dataset

    with World(official_camera(args.width, args.height)) as world:
        episode = gen.realise_config(config, args.seed, args.index, episode_id, world,
                                     executor=args.executor)
    out = args.render / episode_id
    write_dataset(out, lambda _i: episode, 0, 1, shard_size=1, split="sample")
    sys.stderr.write(f"{episode.symbolic.instruction.text}\nwrote {out}\n")
    sys.stdout.write(f"{out}\n")
    return 0
