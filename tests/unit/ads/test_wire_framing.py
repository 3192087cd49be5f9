"""AMS/ADS codec and framer: hand-checked layouts, and hypothesis fuzzing of every decoder and
of the framer (split, coalesced, garbage)."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from liftd.ads import wire
from liftd.ads.constants import AdsErr
from liftd.ads.errors import AdsError, FramingError
from liftd.ads.framing import AmsFramer

NET = bytes([127, 0, 0, 1, 1, 1])
CLIENT = bytes([10, 0, 0, 7, 1, 1])


def frame(command: int, payload: bytes, invoke: int = 1, flags: int = 4) -> bytes:
    header = wire.AmsHeader(NET, 551, CLIENT, 30000, command, flags, 0, 0, invoke)
    return wire.encode_frame(header, payload)


def test_header_layout_by_hand() -> None:
    raw = frame(2, wire.encode_read_request(wire.ReadRequest(0x121301, 0x30095, 1)), invoke=7)
    assert raw[:6] == struct.pack("<HI", 0, 32 + 12)  # AMS/TCP: reserved, length
    assert raw[6:12] == NET and raw[12:14] == (551).to_bytes(2, "little")
    assert raw[14:20] == CLIENT and raw[20:22] == (30000).to_bytes(2, "little")
    assert raw[22:24] == b"\x02\x00" and raw[24:26] == b"\x04\x00"  # Read, request flags
    assert raw[26:30] == (12).to_bytes(4, "little") and raw[34:38] == (7).to_bytes(4, "little")
    assert raw[38:] == bytes.fromhex("011312009500030001000000")
    reply = wire.reply_header(wire.decode_frame(raw).header, 5)
    assert (reply.target_net_id, reply.target_port) == (CLIENT, 30000)
    assert (reply.source_net_id, reply.invoke_id, reply.command) == (NET, 7, 2)


def test_net_ids_and_filetime() -> None:
    assert wire.net_id_bytes("192.168.0.10.1.1") == bytes([192, 168, 0, 10, 1, 1])
    assert wire.net_id_text(NET) == "127.0.0.1.1.1"
    with pytest.raises(ValueError):
        wire.net_id_bytes("1.2.3.4.5")
    assert wire.filetime(0) == 116_444_736_000_000_000  # 1970-01-01 in 100 ns since 1601
    assert wire.filetime(1_500_000_000) == 116_444_736_000_000_000 + 15_000_000


def test_notification_stream_layout() -> None:
    payload = wire.encode_notification([wire.Stamp(5, (wire.Sample(9, b"\x01"),))])
    # length (bytes after the field) 25 = stamps 4 + FILETIME 8 + samples 4 + handle 4 + size 4 + 1
    assert payload == struct.pack("<IIQIII", 25, 1, 5, 1, 9, 1) + b"\x01"
    assert wire.decode_notification(payload) == (wire.Stamp(5, (wire.Sample(9, b"\x01"),)),)
    with pytest.raises(AdsError):
        wire.decode_notification(payload + b"\0")


def test_symbol_entry_layout() -> None:
    entry = wire.SymbolEntry(0x121301, 0x30095, 1, 33, 0x20, b"A", b"BOOL", b"")
    raw = wire.encode_symbol_entry(entry)
    assert len(raw) == 30 + 2 + 5 + 1 and raw[:4] == (38).to_bytes(4, "little")
    assert raw[30:] == b"A\0BOOL\0\0"
    assert wire.decode_symbol_entry(raw) == (entry, 38)


@pytest.mark.parametrize(
    ("decoder", "payload"),
    [
        (wire.decode_read, bytes(11)),
        (wire.decode_read, bytes(13)),
        (wire.decode_write, struct.pack("<III", 1, 2, 4) + b"abc"),  # length lies
        (wire.decode_read_write, struct.pack("<IIII", 1, 2, 4, 2) + b"abc"),
        (wire.decode_add_notification, bytes(39)),
        (wire.decode_del_notification, bytes(5)),
        (wire.decode_write_control, struct.pack("<HHI", 5, 0, 9)),
    ],
)
def test_sizes_that_lie_are_invalid_size(decoder: object, payload: bytes) -> None:
    with pytest.raises(AdsError) as err:
        decoder(payload)  # type: ignore[operator]
    assert err.value.code == AdsErr.INVALIDSIZE


def test_frame_whose_ams_length_disagrees_with_the_tcp_length() -> None:
    raw = bytearray(frame(2, bytes(12)))
    raw[26:30] = (13).to_bytes(4, "little")
    with pytest.raises(AdsError):
        wire.decode_frame(bytes(raw))


DECODERS = [
    wire.decode_read,
    wire.decode_write,
    wire.decode_read_write,
    wire.decode_add_notification,
    wire.decode_del_notification,
    wire.decode_write_control,
    wire.decode_notification,
    wire.decode_read_response,
    wire.decode_state_response,
    wire.decode_device_info_response,
    wire.decode_add_notification_response,
    wire.decode_frame,
    wire.decode_symbol_entry,
]


@given(st.sampled_from(DECODERS), st.binary(max_size=300))
def test_decoders_reject_garbage_only_with_ads_errors(decoder: object, data: bytes) -> None:
    try:
        decoder(data)  # type: ignore[operator]
    except AdsError as exc:
        assert exc.code == AdsErr.INVALIDSIZE
    except struct.error:
        assert decoder is wire.decode_frame and len(data) < 6  # the framer never passes these


# -- framer ---------------------------------------------------------------------------------------
FRAMES = [frame(2, bytes(12), i) for i in range(1, 4)] + [frame(9, bytes(16 + 3000), 9)]


def test_split_and_coalesced_frames() -> None:
    stream = b"".join(FRAMES)
    for cut in range(1, len(stream)):
        framer = AmsFramer(1 << 16)
        assert framer.feed(stream[:cut]) + framer.feed(stream[cut:]) == FRAMES
    framer = AmsFramer(1 << 16)
    assert framer.feed(FRAMES[0][:10]) == [] and framer.pending == 10


def test_frames_over_the_cap_and_impossible_lengths_break_the_stream() -> None:
    with pytest.raises(FramingError):
        AmsFramer(2048).feed(struct.pack("<HI", 0, 2049))
    with pytest.raises(FramingError):
        AmsFramer(2048).feed(struct.pack("<HI", 0, 31) + bytes(31))
    # an AMS router command (reserved ≠ 0) is framed by its length; the server decides
    assert AmsFramer(2048).feed(struct.pack("<HIH", 0x1000, 2, 551)) != []
    # frames complete before the break are handed over with it (they are still answered)
    framer = AmsFramer(2048)
    with pytest.raises(FramingError) as err:
        framer.feed(FRAMES[0] + FRAMES[1] + b"\xff" * 64)
    assert err.value.frames == FRAMES[:2]
    assert framer.pending == 0  # a dead stream holds no memory


@given(st.lists(st.integers(1, 200), min_size=1, max_size=40))
def test_any_chunking_yields_the_same_frames(cuts: list[int]) -> None:
    stream = b"".join(FRAMES) * 2
    framer = AmsFramer(1 << 16)
    got: list[bytes] = []
    pos = 0
    for n in cuts * 100:
        if pos >= len(stream):
            break
        got += framer.feed(stream[pos : pos + n])
        pos += n
    got += framer.feed(stream[pos:])
    assert got == FRAMES * 2


@given(st.binary(max_size=2000))
def test_garbage_either_frames_or_breaks_never_grows_without_bound(data: bytes) -> None:
    framer = AmsFramer(1024)
    try:
        frames = framer.feed(data)
    except FramingError:
        return
    assert sum(len(f) for f in frames) + framer.pending == len(data)
    assert framer.pending < 6 + 1024
