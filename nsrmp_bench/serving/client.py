"""The rollout's end of the protocol: one connection to a policy server, lock-step.

Every wait is bounded: connecting by ``connect_timeout``, each reply by ``timeout`` (the
stalled-server watchdog: a server that sends nothing within it is reported, with the
observation it was asked about, and the rollout stops, resumable). A server that closes
the connection, sends a malformed frame, another major version or an ``error`` raises
:class:`~nsrmp_bench.errors.PolicyServerError` naming the fault.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from typing import Any, Final

from nsrmp_bench._optional import require
from nsrmp_bench._version import __version__
from nsrmp_bench.errors import InvalidArgument, PolicyServerError
from nsrmp_bench.serving.payloads import action_from_payload, observation_payload
from nsrmp_bench.serving.wire import (
    MAX_FRAME_BYTES,
    PROTOCOL,
    PROTOCOL_VERSION,
    Message,
    check_version,
    decode,
    encode,
)

__all__ = ["ConnectionLost", "PolicyClient", "check_url"]

_RESUME: Final = "rerun the same command to resume (finished instances are kept)"


class ConnectionLost(PolicyServerError):
    """The connection closed or could not be opened (a reconnection may help)."""


def check_url(url: str) -> str:
    """``url`` if it is ``ws://HOST:PORT`` (or ``wss://``), else :class:`InvalidArgument`."""
    if not isinstance(url, str) or not url.startswith(("ws://", "wss://")):
        msg = f"--server {url!r} is not a WebSocket URL; give ws://HOST:PORT"
        raise InvalidArgument(msg)
    return url


class PolicyClient:
    """One connection to the policy server at ``url`` (see the module)."""

    def __init__(self, url: str, *, timeout: float = 60.0, connect_timeout: float = 10.0,
                 control: str = "pick_place") -> None:
        if timeout <= 0 or connect_timeout <= 0:
            msg = f"timeouts must be > 0 seconds, got {timeout} and {connect_timeout}"
            raise InvalidArgument(msg)
        self.url = check_url(url)
        self.timeout = float(timeout)
        self.connect_timeout = float(connect_timeout)
        self.control = control
        self._ws: Any = None
        self._stack = contextlib.ExitStack()
        self._seq = 0
        self.server: dict[str, Any] = {}

    def __enter__(self) -> PolicyClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def peer(self) -> str:
        """The server, as messages name it."""
        return f"the policy server at {self.url}"

    def connect(self) -> dict[str, Any]:
        """Open the connection and shake hands; the server's ``hello`` payload."""
        sync_client = require("websockets.sync.client")
        self.close()
        try:
            stack = contextlib.ExitStack()  # websockets wants connect() as a context
            self._ws = stack.enter_context(sync_client.connect(
                self.url, open_timeout=self.connect_timeout, max_size=MAX_FRAME_BYTES,
                compression=None, close_timeout=1.0))
            self._stack = stack
        except TimeoutError as exc:
            msg = (f"{self.peer} did not accept a connection within {self.connect_timeout:g} s; "
                   f"check it is running (nsrmp-bench serve POLICY --port P), then {_RESUME}")
            raise ConnectionLost(msg) from exc
        except (OSError, Exception) as exc:
            msg = (f"cannot connect to {self.peer} ({type(exc).__name__}: {exc}); start it "
                   f"(nsrmp-bench serve POLICY --port P) or fix --server, then {_RESUME}")
            raise ConnectionLost(msg) from exc
        reply = self._ask(Message("hello", {
            "protocol": PROTOCOL, "protocol_version": PROTOCOL_VERSION,
            "harness_version": f"nsrmp-bench {__version__}", "control": self.control}), "hello")
        if "protocol" in reply.payload:  # a vla-eval model server's hello names none
            check_version(reply.payload, self.peer)
        self.server = dict(reply.payload)
        return self.server

    def start_episode(self, config: Mapping[str, Any]) -> None:
        """Send ``episode_start`` (no reply is awaited, as in vla-eval)."""
        self._send(Message("episode_start", dict(config), self._next()))

    def act(self, observation: Mapping[str, Any]) -> dict[str, Any]:
        """The server's action for an environment observation."""
        keys = self.server.get("observation_keys")
        if isinstance(keys, list):  # the server reads only these (and the instruction)
            wanted = {*map(str, keys), "instruction"}
            observation = {k: v for k, v in observation.items() if k in wanted}
        reply = self._ask(Message("observation", observation_payload(observation),
                                  self._next()), "action")
        return action_from_payload(reply.payload, self.control)

    def end_episode(self, result: Mapping[str, Any]) -> None:
        """Send ``episode_end`` with the episode's result."""
        self._send(Message("episode_end", dict(result), self._next()))

    def close(self) -> None:
        """Close the connection (quietly, if it is already gone)."""
        if self._ws is not None:
            with contextlib.suppress(Exception):  # already closed by the peer
                self._stack.close()
            self._ws = None

    # -- internals -----------------------------------------------------------------------
    def _next(self) -> int:
        self._seq += 1
        return self._seq

    def _send(self, message: Message) -> None:
        if self._ws is None:
            msg = f"not connected to {self.peer}; call connect() first"
            raise ConnectionLost(msg)
        try:
            self._ws.send(encode(message))
        except PolicyServerError:
            raise
        except Exception as exc:
            msg = f"{self.peer} closed the connection ({exc}); {_RESUME}"
            raise ConnectionLost(msg) from exc

    def _ask(self, message: Message, expect: str) -> Message:
        self._send(message)
        try:
            frame = self._ws.recv(timeout=self.timeout)
        except TimeoutError as exc:
            self.close()
            msg = (f"{self.peer} sent no reply to {message.type} seq {message.seq} within "
                   f"{self.timeout:g} s (--timeout): it is stalled or far too slow; check it, "
                   f"then {_RESUME}")
            raise PolicyServerError(msg) from exc
        except Exception as exc:
            self.close()
            msg = (f"{self.peer} closed the connection while the rollout waited for its "
                   f"{expect} ({type(exc).__name__}: {exc}); {_RESUME}")
            raise ConnectionLost(msg) from exc
        reply = decode(frame, self.peer)
        if reply.type == "error":
            self.close()
            msg = f"{self.peer} reports an error: {reply.payload.get('error', reply.payload)}"
            raise PolicyServerError(msg)
        if reply.type != expect or reply.seq != message.seq:
            self.close()
            msg = (f"{self.peer} answered {message.type} seq {message.seq} with "
                   f"{reply.type} seq {reply.seq}; expected {expect} seq {message.seq} "
                   "(lock-step)")
            raise PolicyServerError(msg)
        return reply
