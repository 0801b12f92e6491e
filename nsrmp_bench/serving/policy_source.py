"""What a served policy is made from: a registered policy's name, ``module:callable``, or a
callable passed from Python; and the stand-in for the environment it reads.

A registered policy (:mod:`nsrmp_bench.envs.policies`) is built the way ``rollout`` builds
it, once per connection (its state is that connection's). In process a policy may read the
environment (the oracle its episode's gold program, a program model the camera); in a
server it reads :class:`ServedEnv` instead, which knows what the client's
``episode_start`` said (the instance id, the camera, the boxes mode) and, given the part
(``serve --data``), the episode itself, for the privileged policies that read it.
"""

from __future__ import annotations

import importlib
import inspect
import os
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nsrmp_bench.errors import InvalidArgument, PolicyServerError

__all__ = ["PolicyFactory", "ServedEnv", "ServedPolicy", "camera_from_payload",
           "camera_payload", "load_callable", "served_policy"]

PolicyFactory = Callable[["ServedEnv"], Any]
"""Makes one connection's policy from its :class:`ServedEnv`."""

_CAMERA_FIELDS = ("width", "height", "fov_y_deg", "eye", "target", "up", "near", "far")


def camera_payload(camera: Any) -> dict[str, Any]:
    """The camera's parameters as an ``episode_start`` carries them."""
    out: dict[str, Any] = {}
    for name in _CAMERA_FIELDS:
        value = getattr(camera, name)
        out[name] = list(value) if isinstance(value, tuple) else value
    return out


def camera_from_payload(raw: Any) -> Any:
    """The :class:`~nsrmp_bench.geometry.camera.Camera` an ``episode_start`` describes."""
    from nsrmp_bench.geometry.camera import Camera

    if not isinstance(raw, Mapping) or set(_CAMERA_FIELDS) - set(raw):
        msg = (f"episode_start's camera must be a map with {list(_CAMERA_FIELDS)}; got "
               f"{raw!r:.120}")
        raise PolicyServerError(msg)
    try:
        def point(name: str) -> tuple[float, float, float]:
            x, y, z = (float(v) for v in raw[name])
            return (x, y, z)

        return Camera(int(raw["width"]), int(raw["height"]), float(raw["fov_y_deg"]),
                      point("eye"), point("target"), point("up"), float(raw["near"]),
                      float(raw["far"]))
    except (TypeError, ValueError) as exc:
        msg = f"episode_start's camera {raw!r:.120} is malformed ({exc})"
        raise PolicyServerError(msg) from exc


class ServedEnv:
    """What a served policy may read in place of the environment (see the module)."""

    def __init__(self, data: str | Path | None, part: str | None) -> None:
        self.data = data
        self._collection: Any = None
        self._index: dict[str, int] = {}
        if data is not None:
            from nsrmp_bench.storage import open as open_storage

            self._collection = open_storage(Path(data), part=part)
            self._index = {e: i for i, e in enumerate(self._collection.ids)}
        self.camera: Any = None
        self.boxes_mode: str | None = None
        self.instance: str | None = None
        self._episode: Any = None

    @property
    def unwrapped(self) -> ServedEnv:
        """Itself (policies read ``env.unwrapped``)."""
        return self

    def start(self, payload: Mapping[str, Any]) -> None:
        """Take in an ``episode_start``."""
        instance = payload.get("instance")
        task = payload.get("task")  # vla-eval's runner sends {"task": {...}}
        if instance is None and isinstance(task, Mapping):
            instance = task.get("instance", task.get("name"))
        if not isinstance(instance, str) or not instance:
            msg = f"episode_start must name its instance (a string id); got {instance!r}"
            raise PolicyServerError(msg)
        self.instance = instance
        self._episode = None
        boxes = payload.get("boxes")
        self.boxes_mode = boxes if isinstance(boxes, str) else None
        if payload.get("camera") is not None:
            self.camera = camera_from_payload(payload["camera"])

    @property
    def episode(self) -> Any:
        """The current instance's episode, read from the part the server was given."""
        if self._episode is None:
            if self._collection is None:
                msg = (f"this policy reads the episode of instance {self.instance!r} (its gold "
                       "program): start the server with the part, e.g. nsrmp-bench serve "
                       "oracle --data data/smoke/test")
                raise PolicyServerError(msg)
            if self.instance not in self._index:
                msg = (f"instance {self.instance!r} is not in the server's part {self.data} "
                       f"({len(self._index)} instances); serve the part the rollout runs")
                raise PolicyServerError(msg)
            self._episode = self._collection.episode(self._index[self.instance],
                                                     images=False)
        return self._episode


def _current_directory_on_path() -> None:
    here = os.getcwd()
    if not any(os.path.abspath(p or os.curdir) == here for p in sys.path):
        sys.path.insert(0, here)


def load_callable(name: str) -> Any:
    """The object ``module:attr`` names (a class is instantiated with no arguments)."""
    module_name, sep, attr = name.partition(":")
    if not sep or not module_name or not attr:
        msg = f"{name!r} is not 'module:callable'; name e.g. my_policy:policy"
        raise InvalidArgument(msg)
    _current_directory_on_path()
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        msg = (f"policy {name!r}: module {module_name!r} cannot be imported ({exc}); put it "
               "in the current directory or on PYTHONPATH, or install it")
        raise InvalidArgument(msg) from exc
    obj: object = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            msg = f"policy {name!r}: {module_name!r} has no attribute {attr!r}"
            raise InvalidArgument(msg)
        obj = getattr(obj, part)
    if inspect.isclass(obj):
        obj = obj()
    if not callable(obj):
        msg = f"policy {name!r} is a {type(obj).__name__}, not a callable"
        raise InvalidArgument(msg)
    return obj


@dataclass(frozen=True)
class ServedPolicy:
    """A policy as a server offers it: its name (as ``rollout`` names it), the label a
    predictions file's header gives it, the boxes it reads and its factory."""

    name: str
    label: str
    boxes: str | None
    factory: PolicyFactory
    observation_keys: tuple[str, ...] | None = None
    """The observation entries the policy reads (None: all); the rollout sends only these
    (and the instruction)."""


def served_policy(policy: str | Callable[..., Any]) -> ServedPolicy:
    """The :class:`ServedPolicy` of a registered policy's name, ``module:callable`` or a
    callable object. The boxes are ``"gold"`` for the program and dense models (as
    ``rollout`` gives them), else None.

    ``module:callable`` and a callable object are one object shared by every connection
    (calls are serialised); a registered policy is built anew for each connection. Only a
    registered policy imports the environment's package (Gymnasium): a ``module:callable``
    server needs numpy, websockets and msgpack only.
    """
    if not isinstance(policy, str):
        if not callable(policy):
            msg = f"serve needs a policy name or a callable; got a {type(policy).__name__}"
            raise InvalidArgument(msg)
        shared = policy
        label = str(getattr(policy, "__qualname__", None) or type(policy).__name__)
        return ServedPolicy(label, label, None, lambda env: shared)
    if ":" in policy:
        obj = load_callable(policy)
        return ServedPolicy(policy, policy, None, lambda env: obj)
    from nsrmp_bench.envs.policies import make_policy, policy_predictor, reads_boxes

    entry = policy_predictor(policy)
    from nsrmp_bench.predictors import Kind

    boxes = "gold" if reads_boxes(policy) else None
    label = entry.id if entry is not None and boxes is not None else policy
    # a baseline reads the episode, not the observations: the instruction alone is sent
    keys = ("instruction",) if entry is not None and entry.kind is Kind.BASELINE else None
    return ServedPolicy(policy, label, boxes, lambda env: make_policy(policy, env), keys)
