"""The server's answers to a client that breaks the protocol (a real server on 127.0.0.1
in a thread, a real WebSocket client)."""

from __future__ import annotations

import contextlib
import re
import threading
from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip("websockets")

import msgpack
from websockets.sync.client import connect

from nsrmp_bench.errors import PolicyServerError
from nsrmp_bench.serving.client import PolicyClient
from nsrmp_bench.serving.server import PolicyServer
from nsrmp_bench.serving.wire import PROTOCOL, Message, decode, encode


def stop(observation: dict[str, object]) -> dict[str, int]:
    return {"done": 1}


def broken(observation: dict[str, object]) -> dict[str, int]:
    raise ZeroDivisionError("the policy's own bug")


@pytest.fixture()
def server_url(request: pytest.FixtureRequest) -> Iterator[str]:
    server = PolicyServer(getattr(request, "param", stop), port=0)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield server.url
    finally:
        server.shutdown()
        thread.join(timeout=10)


def _hello(version: str = "1.0") -> bytes:
    return encode(Message("hello", {"protocol": PROTOCOL, "protocol_version": version}))


def test_garbage_gets_an_error_and_the_connection_closes(server_url: str) -> None:
    with connect(server_url, open_timeout=5) as ws:
        ws.send(b"\x00\x01 not msgpack")
        reply = decode(ws.recv(timeout=5), "server")
        assert reply.type == "error" and "not one msgpack message" in reply.payload["error"]
        with pytest.raises(Exception, match=r"1002|closed"):
            ws.recv(timeout=5)


def test_another_major_version_is_refused_by_the_server(server_url: str) -> None:
    with connect(server_url, open_timeout=5) as ws:
        ws.send(_hello("9.1"))
        reply = decode(ws.recv(timeout=5), "server")
        assert reply.type == "error" and "major versions differ" in reply.payload["error"]


def test_an_observation_outside_an_episode_is_an_error(server_url: str) -> None:
    with connect(server_url, open_timeout=5) as ws:
        ws.send(_hello())
        assert decode(ws.recv(timeout=5), "server").type == "hello"
        ws.send(msgpack.packb({"type": "observation", "payload": {}, "seq": 3,
                               "timestamp": 0.0}))
        reply = decode(ws.recv(timeout=5), "server")
        assert reply.type == "error" and reply.seq == 3
        assert "outside an episode" in reply.payload["error"]


@pytest.mark.parametrize("server_url", [broken], indirect=True)
def test_a_policy_that_raises_is_reported_to_the_client(server_url: str) -> None:
    import numpy as np

    with PolicyClient(server_url, timeout=5) as client:
        hello = client.connect()
        assert hello["policy"] == "broken"
        client.start_episode({"instance": "x-000000"})
        obs = {"rgb": np.zeros((2, 2, 3), np.uint8), "instruction": "stack them"}
        with pytest.raises(PolicyServerError, match="ZeroDivisionError: the policy's own bug"):
            client.act(obs)


def test_a_client_without_hello_is_served(server_url: str) -> None:
    """vla-eval's older clients send episode_start first."""
    import numpy as np

    with connect(server_url, open_timeout=5) as ws:
        ws.send(encode(Message("episode_start", {"instance": "x-000001"}, seq=1)))
        ws.send(encode(Message("observation", {
            "images": {"main": np.zeros((2, 2, 3), np.uint8)},
            "task_description": "stack them"}, seq=2)))
        reply = decode(ws.recv(timeout=5), "server")
        assert (reply.type, reply.seq, dict(reply.payload)) == ("action", 2, {"done": 1})


@contextlib.contextmanager
def _fake_server(reply: bytes) -> Iterator[str]:
    """A real WebSocket server on 127.0.0.1 that answers every frame with ``reply``."""
    from websockets.sync.server import serve

    def handler(ws: Any) -> None:
        for _ in ws:
            ws.send(reply)

    server = serve(handler, "127.0.0.1", 0)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"ws://127.0.0.1:{server.socket.getsockname()[1]}"
    finally:
        server.shutdown()
        thread.join(timeout=10)


@pytest.mark.parametrize(("reply", "words"), [
    (encode(Message("hello", {"protocol": PROTOCOL, "protocol_version": "9.0"})),
     "major versions differ"),
    (b"\xc1 not msgpack", "not one msgpack message"),
    (encode(Message("action", {"done": 1}, seq=0)), "answered hello seq 0 with action"),
    (encode(Message("hello", {"protocol": "another-protocol"})), "does not speak"),
])
def test_the_client_names_a_server_that_breaks_the_protocol(reply: bytes, words: str) -> None:
    with (_fake_server(reply) as url, PolicyClient(url, timeout=5) as client,
          pytest.raises(PolicyServerError, match=re.escape(words))):
        client.connect()


def test_a_listener_that_never_shakes_hands_is_bounded_by_the_connect_timeout() -> None:
    import socket
    import time

    with socket.socket() as listener:  # accepts TCP, never answers the WebSocket handshake
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        url = f"ws://127.0.0.1:{listener.getsockname()[1]}"
        t0 = time.monotonic()
        with PolicyClient(url, connect_timeout=1.0) as client, \
                pytest.raises(PolicyServerError, match=r"within 1 s|cannot connect"):
            client.connect()
        assert time.monotonic() - t0 < 10


def test_a_callable_server_imports_no_simulator_and_no_torch() -> None:
    """What lets a policy's own venv hold only nsrmp-bench[serve] (docs/policy-server.md)."""
    import subprocess
    import sys

    code = ("import sys; from nsrmp_bench.cli.serve import run; "
            "import nsrmp_bench.reference_model.registry; "
            "from nsrmp_bench.serving.server import PolicyServer; "
            "s = PolicyServer('json:dumps', port=0); s._server.socket.close(); "
            "print(sorted({m.split('.')[0] for m in sys.modules} "
            "& {'torch', 'gymnasium', 'pybullet', 'cv2'}))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout.strip() == "[]"
