"""The policy-server protocol's messages on the wire: one msgpack map per WebSocket frame.

Every frame is a binary WebSocket message holding one msgpack map, the envelope of
vla-eval's protocol (its RFC 0002)::

    {"type": str, "payload": map, "seq": int, "timestamp": float}

``type`` is one of :data:`MESSAGE_TYPES`; in lock-step the server's ``action`` carries the
``seq`` of the ``observation`` it answers. numpy arrays travel inline as the map
``{"__ndarray__": true, "data": bytes, "dtype": str, "shape": [int, ...]}`` (vla-eval's
codec); only boolean, integer and float dtypes are accepted (never object or void dtypes,
which could carry pickles), and the byte count must match the shape. The handshake's
``hello`` names :data:`PROTOCOL` and :data:`PROTOCOL_VERSION` (semver): a peer refuses
another major version. The exact schema of each payload is in ``docs/policy-server.md``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np

from nsrmp_bench._optional import require
from nsrmp_bench.errors import PolicyServerError

__all__ = ["MAX_FRAME_BYTES", "MESSAGE_TYPES", "PROTOCOL", "PROTOCOL_VERSION", "Message",
           "check_version", "decode", "encode"]

PROTOCOL: Final = "nsrmp-bench-policy"
"""The protocol's name, said in both ``hello`` messages."""
PROTOCOL_VERSION: Final = "1.0"
"""Semver: a minor version adds optional fields only; a major version breaks."""
MESSAGE_TYPES: Final = ("hello", "episode_start", "observation", "action", "episode_end",
                        "error")
MAX_FRAME_BYTES: Final = 64 * 2**20
"""The largest frame either end reads (an observation at 320x240 is about 0.6 MB)."""
_NDARRAY: Final = "__ndarray__"
_KINDS: Final = frozenset("biuf")  # bool, signed and unsigned int, float


@dataclass(frozen=True)
class Message:
    """One frame: its type, payload, sequence number and wall-clock send time."""

    type: str
    payload: Mapping[str, Any]
    seq: int = 0
    timestamp: float = field(default_factory=time.time)


def _pack_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind not in _KINDS:
            msg = (f"an array of dtype {obj.dtype} cannot be sent; the protocol carries "
                   "bool, int and float arrays: convert it (e.g. .astype(np.float32))")
            raise PolicyServerError(msg)
        # (np.ascontiguousarray would make a 0-d array 1-d)
        arr = obj if obj.flags.c_contiguous else obj.copy(order="C")
        small = arr.ndim == 0 or arr.size == 0  # memoryview.cast refuses these
        return {_NDARRAY: True, "data": arr.tobytes() if small else arr.data.cast("B"),
                "dtype": arr.dtype.str, "shape": list(arr.shape)}
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    if isinstance(obj, tuple):
        return list(obj)
    msg = (f"a {type(obj).__name__} cannot be sent in a message; send numbers, strings, "
           "lists, maps or numpy arrays")
    raise PolicyServerError(msg)


def _object_hook(obj: dict[Any, Any]) -> Any:
    if obj.get(_NDARRAY) is not True:
        return obj
    try:
        dtype = np.dtype(obj["dtype"])
        shape = tuple(int(n) for n in obj["shape"])
        data = obj["data"]
    except (KeyError, TypeError, ValueError) as exc:
        msg = (f"a malformed array ({exc}); an array is "
               "{'__ndarray__': true, 'data': bytes, 'dtype': str, 'shape': [int, ...]}")
        raise PolicyServerError(msg) from exc
    if dtype.kind not in _KINDS:
        msg = (f"an array of dtype {dtype}; only bool, int and float arrays are accepted "
               "(object and void dtypes could carry pickles)")
        raise PolicyServerError(msg)
    if not isinstance(data, bytes) or any(n < 0 for n in shape):
        msg = f"a malformed array: data {type(data).__name__}, shape {shape}"
        raise PolicyServerError(msg)
    expected = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if len(data) != expected:
        msg = (f"an array of shape {shape} and dtype {dtype} in {len(data)} bytes; it needs "
               f"{expected} bytes: the sender's codec is wrong")
        raise PolicyServerError(msg)
    return np.frombuffer(data, dtype=dtype).reshape(shape).copy()


def encode(message: Message) -> bytes:
    """The frame's bytes."""
    if message.type not in MESSAGE_TYPES:
        msg = f"unknown message type {message.type!r}; expected one of {list(MESSAGE_TYPES)}"
        raise PolicyServerError(msg)
    msgpack = require("msgpack")
    raw = {"type": message.type, "payload": dict(message.payload), "seq": int(message.seq),
           "timestamp": float(message.timestamp)}
    out: bytes = msgpack.packb(raw, default=_pack_default, use_bin_type=True)
    return out


def decode(frame: bytes | str, sender: str) -> Message:
    """The message in ``frame``; :class:`PolicyServerError` naming ``sender`` and the fault
    for anything but a well-formed envelope."""
    if isinstance(frame, str):
        msg = (f"{sender} sent a text frame ({frame[:60]!r}); the protocol sends binary "
               "frames of msgpack")
        raise PolicyServerError(msg)
    if len(frame) > MAX_FRAME_BYTES:
        msg = f"{sender} sent a frame of {len(frame)} bytes; the limit is {MAX_FRAME_BYTES}"
        raise PolicyServerError(msg)
    msgpack = require("msgpack")
    try:
        raw = msgpack.unpackb(frame, object_hook=_object_hook, raw=False,
                              strict_map_key=False)
    except PolicyServerError as exc:
        msg = f"{sender} sent a message with {exc}"
        raise PolicyServerError(msg) from exc
    except Exception as exc:  # msgpack raises several unrelated classes for bad bytes
        msg = (f"{sender} sent {len(frame)} bytes that are not one msgpack message "
               f"({type(exc).__name__}: {exc}); is it speaking {PROTOCOL}?")
        raise PolicyServerError(msg) from exc
    if not isinstance(raw, dict):
        msg = f"{sender} sent a msgpack {type(raw).__name__}; expected a map (the envelope)"
        raise PolicyServerError(msg)
    missing = [k for k in ("type", "payload", "seq") if k not in raw]
    if missing:
        msg = (f"{sender} sent a message without {missing} (keys {sorted(map(str, raw))}); "
               "every message has type, payload, seq and timestamp")
        raise PolicyServerError(msg)
    kind, payload, seq = raw["type"], raw["payload"], raw["seq"]
    if kind not in MESSAGE_TYPES:
        msg = f"{sender} sent a message of type {kind!r}; expected one of {list(MESSAGE_TYPES)}"
        raise PolicyServerError(msg)
    if not isinstance(payload, dict):
        msg = f"{sender} sent a {kind!r} whose payload is a {type(payload).__name__}, not a map"
        raise PolicyServerError(msg)
    if not isinstance(seq, int) or isinstance(seq, bool):
        msg = f"{sender} sent a {kind!r} whose seq is {seq!r}; expected an integer"
        raise PolicyServerError(msg)
    stamp = raw.get("timestamp", 0.0)
    return Message(kind, payload, seq, float(stamp) if isinstance(stamp, (int, float)) else 0.0)


def check_version(payload: Mapping[str, Any], sender: str) -> str:
    """The peer's protocol version from its ``hello``; :class:`PolicyServerError` unless it
    speaks :data:`PROTOCOL` with this major version."""
    name = payload.get("protocol")
    version = payload.get("protocol_version")
    if name != PROTOCOL or not isinstance(version, str):
        msg = (f"{sender} does not speak {PROTOCOL} (its hello says protocol={name!r}, "
               f"protocol_version={version!r}); point it at an nsrmp-bench policy server or "
               "rollout")
        raise PolicyServerError(msg)
    major = version.split(".", 1)[0]
    if major != PROTOCOL_VERSION.split(".", 1)[0]:
        msg = (f"{sender} speaks {PROTOCOL} {version}, this end {PROTOCOL_VERSION}: major "
               "versions differ; install the same major release of nsrmp-bench at both ends")
        raise PolicyServerError(msg)
    return version
