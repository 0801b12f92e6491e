"""The options that choose where a verb's tasks run: ``--engine``, ``--workers``, ``--scheduler``.

Every verb that hands out many tasks (``generate``, ``verify``, ``replay``,
``evaluate``) adds them with :func:`add_engine_arguments` and opens the engine with
:func:`engine_from_args`, so the options mean the same everywhere.
"""

from __future__ import annotations

import argparse

from nsrmp_bench.cli.numbers import positive_int
from nsrmp_bench.engine import ENGINES, Engine, open_engine

__all__ = ["add_engine_arguments", "engine_from_args"]


def add_engine_arguments(parser: argparse.ArgumentParser, *, workers: int) -> None:
    """Add the engine options; ``workers`` is the verb's default worker count."""
    parser.add_argument("--engine", choices=ENGINES, default="local",
                        help="where tasks run: local (a process pool on the local machine, the "
                             "default) or dask (a Dask cluster; needs the dask extra)")
    parser.add_argument("--workers", type=positive_int, default=workers,
                        help=f"local worker processes (default {workers}; 1 runs "
                             "in this process); with --engine dask, the LocalCluster's size")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="with --engine dask: a running scheduler, e.g. "
                             "tcp://HOST:8786 (default: start a LocalCluster on the local machine)")


def engine_from_args(args: argparse.Namespace) -> Engine:
    """The engine the options name (not entered yet)."""
    return open_engine(args.engine, workers=args.workers, scheduler=args.scheduler)
