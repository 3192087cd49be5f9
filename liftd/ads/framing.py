"""Sans-IO incremental AMS/TCP framer: bytes as they arrive in, whole frames out.

Frames may be split across reads or coalesced (pyads' test server gets this wrong, ads.md
§1.1). The AMS/TCP length decides where a frame ends; a length above the cap, or one too short
to hold an AMS header, breaks the stream for good: FramingError, and the server closes.
Frames are cut one at a time as the server handles them (`next`).
"""

from __future__ import annotations

from liftd.ads.errors import FramingError
from liftd.ads.wire import AMS_SIZE, TCP_HEADER, TCP_SIZE


class AmsFramer:
    def __init__(self, max_frame_bytes: int) -> None:
        self.max_frame_bytes = max_frame_bytes
        self._buf = bytearray()
        self._pos = 0  # where the next frame starts in `_buf`

    def add(self, data: bytes) -> None:
        """Add received bytes; `next` cuts them into frames, one at a time (the server cuts
        only as many as a connection's turn handles: 64 kB of small requests are ~1 500
        frames, and cutting them all at once was a few ms of the event loop)."""
        self._buf += data

    def next(self) -> bytes | None:
        """The next complete frame (6-byte AMS/TCP header included), or None until more bytes
        come. Raises FramingError for a frame the stream cannot recover from (the frames
        before it were returned), and holds nothing of the stream after it."""
        buf, pos = self._buf, self._pos
        if len(buf) - pos < TCP_SIZE:
            self._compact()
            return None
        reserved, length = TCP_HEADER.unpack_from(buf, pos)
        if length > self.max_frame_bytes:
            self.clear()  # the stream is dead: hold nothing of it
            raise FramingError(f"frame of {length} bytes over the cap {self.max_frame_bytes}", [])
        if reserved == 0 and length < AMS_SIZE:
            self.clear()
            raise FramingError(f"AMS/TCP length {length} cannot hold an AMS header", [])
        end = pos + TCP_SIZE + length
        if end > len(buf):
            self._compact()
            return None
        self._pos = end
        return bytes(buf[pos:end])

    def _compact(self) -> None:
        if self._pos:
            del self._buf[: self._pos]  # once the frames cut so far are all handed out
            self._pos = 0

    def feed(self, data: bytes) -> list[bytes]:
        """Add received bytes; return every frame now complete. Raises FramingError for a
        frame the stream cannot recover from; the frames complete before it travel in the
        exception. (Clients and tests; the server uses `add` and `next`.)"""
        self.add(data)
        frames: list[bytes] = []
        try:
            while (frame := self.next()) is not None:
                frames.append(frame)
        except FramingError as exc:
            raise FramingError(str(exc), frames) from None
        return frames

    def clear(self) -> None:
        """Drop what is held (a broken stream, or the connection closed)."""
        self._buf = bytearray()
        self._pos = 0

    @property
    def pending(self) -> int:
        """Bytes held: frames not cut yet and an incomplete one (its idle timeout)."""
        return len(self._buf) - self._pos
