"""The policy server: ``nsrmp-bench serve POLICY --port P`` and :func:`serve`.

Example::

    import nsrmp_bench

    def policy(observation):          # any callable observation -> action
        return {"done": 1}

    nsrmp_bench.serve(policy, port=8765)   # blocks; Ctrl-C stops it

One WebSocket connection is one rollout client; each gets its own policy (a registered
policy is built per connection; a callable is shared, its calls serialised). The server
answers ``hello`` with its own, each ``observation`` with an ``action`` of the same
``seq``, and anything it cannot take (a malformed frame, another major version, an
observation before ``episode_start``, a policy that raises) with an ``error`` naming the
fault; a malformed frame or a wrong version also closes the connection. A client that
sends no ``hello`` (vla-eval's older clients) is served as one of this major version. The policy's
``reset(observation, info)``, where it has one, is called on each episode's first
observation.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, Final

from nsrmp_bench._optional import require
from nsrmp_bench._version import __version__
from nsrmp_bench.errors import NSRMPError, PolicyServerError
from nsrmp_bench.serving.payloads import action_payload, observation_from_payload
from nsrmp_bench.serving.policy_source import ServedEnv, ServedPolicy, served_policy
from nsrmp_bench.serving.wire import (
    MAX_FRAME_BYTES,
    PROTOCOL,
    PROTOCOL_VERSION,
    Message,
    check_version,
    decode,
    encode,
)

__all__ = ["PolicyServer", "serve"]

_CLIENT: Final = "the rollout client"


class _Session:
    """One connection's state: its policy, its stand-in environment, its episode."""

    def __init__(self, offered: ServedPolicy, data: str | Path | None, part: str | None,
                 lock: threading.Lock) -> None:
        self.offered = offered
        self.env = ServedEnv(data, part)
        self.lock = lock
        self.policy: Any = None
        self.in_episode = False
        self.fresh = False

    def hello(self, message: Message) -> dict[str, Any]:
        if "protocol" in message.payload:  # a vla-eval client's hello names none
            check_version(message.payload, _CLIENT)
        return {"protocol": PROTOCOL, "protocol_version": PROTOCOL_VERSION,
                "harness_version": f"nsrmp-bench {__version__}", "model_server": "nsrmp-bench",
                "policy": self.offered.name, "label": self.offered.label,
                "boxes": self.offered.boxes,
                "observation_keys": (None if self.offered.observation_keys is None
                                     else list(self.offered.observation_keys))}

    def start(self, message: Message) -> None:
        # a client without hello (vla-eval's older clients send none) is served as 1.x
        self.env.start(message.payload)
        if self.policy is None:
            self.policy = self.offered.factory(self.env)
        self.in_episode = True
        self.fresh = True

    def act(self, message: Message) -> dict[str, Any]:
        if not self.in_episode:
            msg = (f"observation seq {message.seq} outside an episode; send episode_start "
                   "(after hello) first")
            raise PolicyServerError(msg)
        observation = observation_from_payload(message.payload)
        with self.lock:
            if self.fresh:
                reset = getattr(self.policy, "reset", None)
                if callable(reset):
                    reset(observation, {"instance": self.env.instance})
                self.fresh = False
            return action_payload(self.policy(observation))


class PolicyServer:
    """A policy served over WebSocket; :meth:`serve_forever` runs it (see the module)."""

    def __init__(self, policy: str | Callable[..., Any], *, host: str = "127.0.0.1",
                 port: int = 0, data: str | Path | None = None, part: str | None = None,
                 observation_keys: Sequence[str] | None = None) -> None:
        sync_server = require("websockets.sync.server")
        require("msgpack")
        self.offered = served_policy(policy)
        if observation_keys is not None:
            self.offered = replace(self.offered, observation_keys=tuple(observation_keys))
        self.data, self.part = data, part
        if data is not None:
            ServedEnv(data, part)  # a wrong part is said now, not at the first episode
        self._lock = threading.Lock()
        try:
            self._server = sync_server.serve(self._handle, host, port,
                                             max_size=MAX_FRAME_BYTES, compression=None,
                                             ping_interval=None)
        except OSError as exc:
            msg = (f"cannot listen on {host}:{port} ({exc}); choose another --port (0 picks "
                   "a free one) or stop what holds it")
            raise PolicyServerError(msg) from exc
        self.host = host
        self.port = int(self._server.socket.getsockname()[1])

    @property
    def url(self) -> str:
        """``ws://host:port``."""
        return f"ws://{self.host}:{self.port}"

    def serve_forever(self) -> None:
        """Serve until :meth:`shutdown` (from another thread) or Ctrl-C."""
        self._server.serve_forever()

    def shutdown(self) -> None:
        """Stop :meth:`serve_forever`."""
        self._server.shutdown()

    def _handle(self, ws: Any) -> None:
        session = _Session(self.offered, self.data, self.part, self._lock)
        for frame in ws:
            try:
                message = decode(frame, _CLIENT)
            except PolicyServerError as exc:
                self._send(ws, Message("error", {"error": str(exc)}))
                ws.close(1002, "malformed message")
                return
            try:
                if message.type == "hello":
                    self._send(ws, Message("hello", session.hello(message), message.seq))
                elif message.type == "episode_start":
                    session.start(message)
                elif message.type == "observation":
                    action = session.act(message)
                    self._send(ws, Message("action", action, message.seq))
                elif message.type == "episode_end":
                    session.in_episode = False
                elif message.type == "error":
                    print(f"the rollout client reports: {message.payload.get('error')}",
                          file=sys.stderr)
                else:
                    msg = f"a client does not send {message.type!r} messages"
                    raise PolicyServerError(msg)
            except Exception as exc:  # the policy's own faults go back to the client
                text = str(exc) if isinstance(exc, NSRMPError) else (
                    f"the policy {self.offered.name!r} raised {type(exc).__name__}: {exc}")
                self._send(ws, Message("error", {"error": text}, message.seq))
                if message.type == "hello":
                    ws.close(1002, "protocol version")
                    return

    @staticmethod
    def _send(ws: Any, message: Message) -> None:
        try:
            ws.send(encode(message))
        except Exception:  # the client went away: its loop ends the connection
            return


def serve(policy: str | Callable[..., Any], *, port: int = 8765, host: str = "127.0.0.1",
          data: str | Path | None = None, part: str | None = None,
          observation_keys: Sequence[str] | None = None,
          ready: Callable[[str], None] | None = None) -> None:
    """Serve ``policy`` (a registered policy's name, ``module:callable`` or a callable
    ``observation -> action``) on ``ws://host:port`` until interrupted. ``data`` (and
    ``part``) give the part a privileged policy (``oracle``) reads its episodes from;
    ``observation_keys`` names the observation entries the policy reads (the rollout then
    sends only these and the instruction; default all); ``ready`` is called with the URL
    once the server listens (``port=0`` picks a free port)."""
    server = PolicyServer(policy, host=host, port=port, data=data, part=part,
                          observation_keys=observation_keys)
    if ready is not None:
        ready(server.url)
    server.serve_forever()
