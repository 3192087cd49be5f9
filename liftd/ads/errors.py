"""Errors that carry their wire code. The service layer is the one place that turns an
`AdsError` into a result field; `FramingError` makes the server close the connection (the
byte stream cannot be resynchronised)."""

from __future__ import annotations

from liftd.ads.constants import AdsErr


class AdsError(Exception):
    """A request failed with an ADS device error (result field of the response)."""

    def __init__(self, code: AdsErr | int, message: str = "") -> None:
        super().__init__(message or f"ADS error 0x{int(code):X}")
        self.code = int(code)


class FramingError(Exception):
    """The AMS/TCP stream is broken (length over the cap, impossible header). `frames` holds
    the complete frames that arrived before the break: they are still answered."""

    def __init__(self, message: str, frames: list[bytes] | None = None) -> None:
        super().__init__(message)
        self.frames: list[bytes] = frames or []
