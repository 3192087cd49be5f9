"""AMS port 10000, the TwinCAT system service, as far as clients ask it while connecting: the
system state (RUN while liftd serves), device info, and ads-client's extended system state.
Everything else is answered "service not supported" (0x701). Pure.

ads-client 2.1.0 (`src/ads-client.ts` setupPlcConnection) reads IG 0xF0 IO 0, 16 bytes, on
port 10000 (readTcSystemExtendedState: ADS state u16, device state u16, restart index u16,
version u8, revision u8, build u16, platform u8, OS type u8, flags u16, 2 reserved) and falls
back to ReadState there (readTcSystemState); it refuses to connect unless the state is RUN.
"""

from __future__ import annotations

import struct

from liftd.ads import wire
from liftd.ads.constants import SYSTEM_EXTENDED_STATE, AdsErr, AdsState, Command
from liftd.ads.device import error_payload
from liftd.ads.errors import AdsError

EXTENDED_STATE = struct.Struct("<HHHBBHBBH2s")
VERSION = (3, 1, 4024)  # the TwinCAT 3.1 build whose ADS services liftd follows


class SystemService:
    def __init__(self, name: str = "liftd system") -> None:
        self.name = name

    def handle(self, command: int, payload: bytes) -> bytes:
        """Answer one request to port 10000; never raises."""
        try:
            if command == Command.READ_STATE:
                return wire.state_response(0, AdsState.RUN, 0)
            if command == Command.READ_DEVICE_INFO:
                return wire.device_info_response(0, *VERSION, self.name.encode("ascii"))
            if command == Command.READ:
                return wire.read_response(0, self._read(wire.decode_read(payload)))
            raise AdsError(AdsErr.SRVNOTSUPP, f"command {command} on the system service")
        except AdsError as exc:
            return error_payload(command, exc.code)

    def _read(self, req: wire.ReadRequest) -> bytes:
        if req.index_group != SYSTEM_EXTENDED_STATE:
            raise AdsError(AdsErr.SRVNOTSUPP, f"index group 0x{req.index_group:X}")
        if req.index_offset != 0:
            raise AdsError(AdsErr.INVALIDOFFSET, f"index offset {req.index_offset}")
        if req.length < EXTENDED_STATE.size:
            raise AdsError(AdsErr.INVALIDSIZE, f"the extended state is {EXTENDED_STATE.size} B")
        return EXTENDED_STATE.pack(AdsState.RUN, 0, 0, *VERSION, 0, 0, 0, bytes(2))
