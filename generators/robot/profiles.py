"""Motion profiles of the Panda pick-and-place controller: speeds, timings, clearances.

Two profiles are registered. ``fast`` is for generating data (about 3.8 s of simulated
time and 0.3 s of one core per pick-and-place); ``realistic`` moves at speeds a real Panda
would be run at near people (about 11.7 s simulated, 1.7 s of one core). Both keep the
same geometry (grasp heights, clearances), so they differ in time, not in where objects
end up, apart from physics noise (sub-millimetre).

``time_step`` is the physics step while the robot moves and ``solver_residual_threshold``
lets the constraint solver stop early once converged (PyBullet's default 1e-7; the world
runs every iteration); ``None`` keeps the world's setting. The robot switches to them for
the pick-and-place and restores the world's afterwards.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Final

from nsrmp_bench.errors import InvalidArgument, UnknownId

__all__ = ["PROFILES", "ROBOT_EXECUTOR_ID", "MotionProfile", "get_profile"]

ROBOT_EXECUTOR_ID: Final = "robot-v1"
"""Version id of the controller's behaviour (geometry, phases, success criterion)."""


@dataclass(frozen=True)
class MotionProfile:
    """How fast the robot moves and how long it waits.

    Speeds are in m/s (Cartesian, end effector) and rad/s (largest joint in joint-space
    moves); times in seconds of simulated time. ``ik_every``: inverse kinematics is
    computed every that many physics steps during Cartesian moves. ``record_hz``: rate of
    the recorded trajectory.
    """

    name: str
    travel_speed: float
    vertical_speed: float
    joint_speed: float
    close_time: float
    open_time: float
    hold_time: float
    ik_every: int
    record_hz: float = 30.0
    time_step: float | None = None
    solver_residual_threshold: float | None = None
    min_segment_time: float = 0.12

    def __post_init__(self) -> None:
        for name in ("travel_speed", "vertical_speed", "joint_speed", "record_hz",
                     "min_segment_time"):
            value = getattr(self, name)
            if not value > 0.0:
                msg = f"MotionProfile.{name} must be > 0, got {value!r}; use a positive value"
                raise InvalidArgument(msg)
        for name in ("close_time", "open_time", "hold_time"):
            value = getattr(self, name)
            if not value >= 0.0:
                msg = f"MotionProfile.{name} must be >= 0 seconds, got {value!r}"
                raise InvalidArgument(msg)
        if self.ik_every < 1:
            msg = f"MotionProfile.ik_every must be >= 1 physics step, got {self.ik_every}"
            raise InvalidArgument(msg)
        if self.time_step is not None and not 0.0 < self.time_step <= 0.01:
            msg = (
                f"MotionProfile.time_step must be in (0, 0.01] s or None (keep the world's), "
                f"got {self.time_step!r}"
            )
            raise InvalidArgument(msg)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form (stored with a robot rendering)."""
        return asdict(self)


PROFILES: Final[dict[str, MotionProfile]] = {
    "fast": MotionProfile(
        name="fast",
        travel_speed=0.6,
        vertical_speed=0.3,
        joint_speed=2.5,
        close_time=0.2,
        open_time=0.1,
        hold_time=0.05,
        ik_every=4,
        solver_residual_threshold=1e-7,
    ),
    "realistic": MotionProfile(
        name="realistic",
        travel_speed=0.25,
        vertical_speed=0.08,
        joint_speed=0.8,
        close_time=0.5,
        open_time=0.3,
        hold_time=0.1,
        ik_every=1,
    ),
}
"""The registered profiles, by name."""


def get_profile(profile: str | MotionProfile) -> MotionProfile:
    """The profile named ``profile`` (a :class:`MotionProfile` passes through)."""
    if isinstance(profile, MotionProfile):
        return profile
    try:
        return PROFILES[profile]
    except KeyError:
        msg = f"unknown motion profile {profile!r}; expected one of {sorted(PROFILES)}"
        raise UnknownId(msg) from None
