"""Golden AMS frames captured from pyads (tests/golden/ads/capture.py) decode and re-encode
byte-exactly, and come out of the framer whole whether fed at once, split or byte by byte."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from liftd.ads import wire
from liftd.ads.constants import Command, StateFlag
from liftd.ads.framing import AmsFramer
from tests.support.paths import GOLDEN

LINES = [
    line.split()
    for line in (GOLDEN / "ads" / "pyads.hex").read_text().splitlines()
    if line and not line.startswith("#")
]
FRAMES = [(tag, bytes.fromhex(hexa)) for tag, hexa in LINES]

REQUESTS: dict[int, tuple[Callable[[bytes], object], Callable[..., bytes]]] = {
    Command.READ: (wire.decode_read, wire.encode_read_request),
    Command.WRITE: (wire.decode_write, wire.encode_write_request),
    Command.READ_WRITE: (wire.decode_read_write, wire.encode_read_write_request),
    Command.ADD_NOTIFICATION: (wire.decode_add_notification, wire.encode_add_notification_request),
    Command.DEL_NOTIFICATION: (wire.decode_del_notification, lambda h: h.to_bytes(4, "little")),
}
RESPONSES: dict[int, tuple[Callable[[bytes], object], Callable[..., bytes]]] = {
    Command.READ_DEVICE_INFO: (wire.decode_device_info_response, wire.device_info_response),
    Command.READ: (wire.decode_read_response, wire.read_response),
    Command.READ_WRITE: (wire.decode_read_response, wire.read_response),
    Command.WRITE: (wire.decode_result, wire.result_only),
    Command.DEL_NOTIFICATION: (wire.decode_result, wire.result_only),
    Command.READ_STATE: (wire.decode_state_response, wire.state_response),
    Command.ADD_NOTIFICATION: (
        wire.decode_add_notification_response,
        wire.add_notification_response,
    ),
}


def test_the_capture_covers_every_command_pyads_sends() -> None:
    commands = {wire.decode_frame(raw).header.command for _, raw in FRAMES}
    assert commands == {1, 2, 3, 4, 6, 7, 8, 9}
    groups = {
        wire.decode_read_write(wire.decode_frame(raw).payload).index_group
        for tag, raw in FRAMES
        if tag == "C" and wire.decode_frame(raw).header.command == Command.READ_WRITE
    }
    assert groups == {0xF003, 0xF009, 0xF080, 0xF081}  # handles, symbol info, sum read/write


@pytest.mark.parametrize(("tag", "raw"), FRAMES, ids=[f"{t}{i}" for i, (t, _) in enumerate(FRAMES)])
def test_frame_decodes_and_reencodes_byte_exactly(tag: str, raw: bytes) -> None:
    frame = wire.decode_frame(raw)
    assert wire.encode_frame(frame.header, frame.payload, frame.reserved) == raw
    cmd = frame.header.command
    is_response = bool(frame.header.flags & StateFlag.RESPONSE)
    assert is_response == (tag == "S" and cmd != Command.NOTIFICATION)
    if cmd == Command.NOTIFICATION:
        assert frame.header.flags == 0x0004  # sent as a request (docs/reference/ads.md §1.4)
        stamps = wire.decode_notification(frame.payload)
        assert wire.encode_notification(stamps) == frame.payload
        return
    table = RESPONSES if is_response else REQUESTS
    if cmd not in table:  # requests without payload
        assert frame.payload == b""
        return
    decode, encode = table[cmd]
    value = decode(frame.payload)
    args = value if isinstance(value, tuple) and not hasattr(value, "_fields") else (value,)
    assert encode(*args) == frame.payload


@pytest.mark.parametrize("chunk", [len(b"".join(r for _, r in FRAMES)), 7, 1])
def test_the_framer_returns_the_same_frames_however_the_bytes_arrive(chunk: int) -> None:
    for side in "CS":
        frames = [raw for tag, raw in FRAMES if tag == side]
        stream = b"".join(frames)
        framer = AmsFramer(1 << 20)
        got = []
        for i in range(0, len(stream), chunk):
            got += framer.feed(stream[i : i + chunk])
        assert got == frames and framer.pending == 0
