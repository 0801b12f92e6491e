"""The protocol's frames: the envelope, the numpy codec, the version check."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("msgpack")

import msgpack

from nsrmp_bench.errors import PolicyServerError
from nsrmp_bench.serving.payloads import observation_from_payload, observation_payload
from nsrmp_bench.serving.wire import (
    PROTOCOL,
    PROTOCOL_VERSION,
    Message,
    check_version,
    decode,
    encode,
)


def test_arrays_and_scalars_round_trip_exactly() -> None:
    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, (24, 32, 3), dtype=np.uint8)
    depth = rng.random((24, 32)).astype(np.float32)
    payload = {"images": {"main": rgb}, "depth": depth, "n": np.int64(7),
               "f": np.float32(0.5), "flag": np.bool_(True), "pair": (1.25, 2.5)}
    back = decode(encode(Message("observation", payload, seq=4)), "test")
    assert back.type == "observation" and back.seq == 4
    assert back.payload["images"]["main"].dtype == np.uint8
    np.testing.assert_array_equal(back.payload["images"]["main"], rgb)
    assert back.payload["depth"].tobytes() == depth.tobytes()
    assert back.payload["n"] == 7 and back.payload["flag"] is True
    assert back.payload["pair"] == [1.25, 2.5]


@pytest.mark.parametrize("array", [
    np.array(3.5), np.array([True, False]), np.zeros((0, 4), np.float32),
    np.arange(6, dtype=">i4").reshape(2, 3), np.arange(12.0).reshape(3, 4)[:, ::2]])
def test_every_shape_and_byte_order_round_trips(array: np.ndarray) -> None:
    back = decode(encode(Message("action", {"a": array})), "test").payload["a"]
    assert back.dtype == array.dtype and back.shape == array.shape
    np.testing.assert_array_equal(back, array)


def test_the_observation_payload_carries_vla_eval_field_names() -> None:
    obs = {"rgb": np.zeros((2, 2, 3), np.uint8), "depth": np.ones((2, 2), np.float32),
           "instruction": "put the red cube on the blue dice"}
    payload = observation_payload(obs)
    assert payload["task_description"] == obs["instruction"]
    assert "rgb" not in payload and payload["images"]["main"] is obs["rgb"]
    assert set(observation_from_payload(payload)) == set(obs)


def _frame(raw: object) -> bytes:
    out: bytes = msgpack.packb(raw, use_bin_type=True)
    return out


@pytest.mark.parametrize(("frame", "words"), [
    (b"\xc1\x00garbage", "not one msgpack message"),
    (_frame([1, 2, 3]), "expected a map"),
    (_frame({"type": "action", "payload": {}}), "without ['seq']"),
    (_frame({"type": "teleport", "payload": {}, "seq": 1}), "type 'teleport'"),
    (_frame({"type": "action", "payload": [], "seq": 1}), "payload is a list"),
    (_frame({"type": "action", "payload": {}, "seq": "1"}), "seq is '1'"),
    (_frame({"type": "action", "seq": 1, "payload": {"a": {
        "__ndarray__": True, "data": b"\x00" * 8, "dtype": "|O", "shape": [1]}}}),
     "only bool, int and float"),
    (_frame({"type": "action", "seq": 1, "payload": {"a": {
        "__ndarray__": True, "data": b"\x00" * 7, "dtype": "<f8", "shape": [1]}}}),
     "needs 8 bytes"),
])
def test_malformed_frames_are_named(frame: bytes, words: str) -> None:
    with pytest.raises(PolicyServerError, match="the peer") as err:
        decode(frame, "the peer")
    assert words in str(err.value)


def test_a_text_frame_is_refused() -> None:
    with pytest.raises(PolicyServerError, match="text frame"):
        decode('{"type": "action"}', "the peer")


def test_object_arrays_are_not_sent() -> None:
    with pytest.raises(PolicyServerError, match="dtype object"):
        encode(Message("action", {"a": np.array([object()])}))


def test_versions() -> None:
    assert check_version({"protocol": PROTOCOL, "protocol_version": "1.7"}, "x") == "1.7"
    major = int(PROTOCOL_VERSION.split(".")[0]) + 1
    with pytest.raises(PolicyServerError, match="major versions differ"):
        check_version({"protocol": PROTOCOL, "protocol_version": f"{major}.0"}, "the server")
    with pytest.raises(PolicyServerError, match="does not speak"):
        check_version({"protocol": "something-else"}, "the server")
