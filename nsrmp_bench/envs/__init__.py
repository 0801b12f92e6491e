"""Closed-loop evaluation as a Gymnasium environment (the ``gym`` extra).

Importing this package registers the environment ids with Gymnasium::

    import gymnasium as gym
    import nsrmp_bench.envs

    env = gym.make("nsrmp_bench/Tabletop-v0", data="data/smoke", part="test")

Gymnasium's convention for environment packages holds whatever the import order:
``gym.register_envs(nsrmp_bench.envs)`` after ``import nsrmp_bench.envs``, or the id
``"nsrmp_bench.envs:nsrmp_bench/Tabletop-v0"`` (Gymnasium imports the module first).
``import nsrmp_bench`` alone registers nothing (no import-order effect). The
environment class lives in :mod:`nsrmp_bench.envs.tabletop` and is imported only by
``gym.make`` (a string entry point), so registering costs no PyBullet import.
"""

from __future__ import annotations

from typing import Final

from nsrmp_bench._optional import require

__all__ = ["ENV_IDS", "register_envs"]

ENV_IDS: Final = ("nsrmp_bench/Tabletop-v0",)
"""The registered environment ids."""


def register_envs() -> None:
    """Register :data:`ENV_IDS` with Gymnasium (idempotent); without Gymnasium,
    :class:`~nsrmp_bench.errors.MissingExtra` names the ``gym`` extra."""
    registration = require("gymnasium.envs.registration")
    if "nsrmp_bench/Tabletop-v0" not in registration.registry:
        registration.register(id="nsrmp_bench/Tabletop-v0",
                              entry_point="nsrmp_bench.envs.tabletop:TabletopEnv")


register_envs()
