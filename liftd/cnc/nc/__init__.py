"""NC decoder: DIN 66025 subset of the ISG dialect plus the lift syntax (vendor text §3)."""

from __future__ import annotations

from liftd.cnc.nc.blocks import (
    Block,
    DecodeResult,
    ErrorId,
    FlushKind,
    LiftEnd,
    LiftEndCause,
    LiftStart,
    Motion,
    MotionKind,
    NcError,
    Severity,
)
from liftd.cnc.nc.context import DecoderContext
from liftd.cnc.nc.decoder import decode

__all__ = [
    "Block",
    "DecodeResult",
    "DecoderContext",
    "ErrorId",
    "FlushKind",
    "LiftEnd",
    "LiftEndCause",
    "LiftStart",
    "Motion",
    "MotionKind",
    "NcError",
    "Severity",
    "decode",
]
