"""Sans-IO incremental AMS/TCP framer: bytes as they arrive in, whole frames out.

Frames may be split across reads or coalesced (pyads' test server gets this wrong, ads.md
§1.1). The AMS/TCP length decides where a frame ends; a length above the cap, or one too short
to hold an AMS header, breaks the stream for good: FramingError, and the server closes.
"""

from __future__ import annotations

from liftd.ads.errors import FramingError
from liftd.ads.wire import AMS_SIZE, TCP_HEADER, TCP_SIZE


class AmsFramer:
    def __init__(self, max_frame_bytes: int) -> None:
        self.max_frame_bytes = max_frame_bytes
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[bytes]:
        """Add received bytes; return every frame now complete (6-byte AMS/TCP header
        included). Raises FramingError for a frame the stream cannot recover from; the frames
        complete before it travel in the exception."""
        buf = self._buf
        buf += data
        frames: list[bytes] = []
        pos = 0
        end_buf = len(buf)
        while end_buf - pos >= TCP_SIZE:
            reserved, length = TCP_HEADER.unpack_from(buf, pos)
            if length > self.max_frame_bytes:
                buf.clear()  # the stream is dead: hold nothing of it
                raise FramingError(
                    f"frame of {length} bytes over the cap {self.max_frame_bytes}", frames
                )
            if reserved == 0 and length < AMS_SIZE:
                buf.clear()
                raise FramingError(f"AMS/TCP length {length} cannot hold an AMS header", frames)
            end = pos + TCP_SIZE + length
            if end > end_buf:
                break
            frames.append(bytes(buf[pos:end]))
            pos = end
        if pos:
            del buf[:pos]  # one compaction per feed, not per frame
        return frames

    def clear(self) -> None:
        """Drop an incomplete frame (the connection closed)."""
        self._buf = bytearray()

    @property
    def pending(self) -> int:
        """Bytes of an incomplete frame held back (for the idle timeout of half frames)."""
        return len(self._buf)
