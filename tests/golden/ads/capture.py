"""Capture golden AMS frames from a real client: pyads (Beckhoff's AdsLib inside) talks to
liftd's ADS server through a recording TCP proxy; every frame of both directions is written as
one hex line ("C " client → server, "S " server → client) to pyads.hex next to this file.

Run (re-creates the file): .venv/bin/python tests/golden/ads/capture.py
"""

from __future__ import annotations

import contextlib
import socket
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

import pyads  # noqa: E402

from liftd.ads.framing import AmsFramer  # noqa: E402
from tests.support.ads_harness import Harness  # noqa: E402
from tests.support.channel import make_channel  # noqa: E402


def proxy(listen: socket.socket, target_port: int, log: list[tuple[str, bytes]]) -> None:
    client, _ = listen.accept()
    upstream = socket.create_connection(("127.0.0.1", target_port))
    for s in (client, upstream):
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def pump(src: socket.socket, dst: socket.socket, tag: str) -> None:
        framer = AmsFramer(1 << 24)
        while data := src.recv(65536):
            for frame in framer.feed(data):
                log.append((tag, frame))
            dst.sendall(data)
        dst.close()

    threading.Thread(target=pump, args=(client, upstream, "C"), daemon=True).start()
    pump(upstream, client, "S")


def main() -> None:
    log: list[tuple[str, bytes]] = []
    with Harness(make_channel()) as h:
        listen = socket.create_server(("127.0.0.1", 0))
        threading.Thread(target=proxy, args=(listen, h.port, log), daemon=True).start()
        plc = pyads.Connection(h.net_id, 551, f"127.0.0.1:{listen.getsockname()[1]}")
        plc.open()
        plc.read_device_info()
        plc.read_state()
        plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL)
        plc.read(0x121401, 0x30095, pyads.PLCTYPE_STRING)
        plc.read_by_name("GEO.ch1.Z.lift_active", pyads.PLCTYPE_BOOL)
        plc.read_list_by_name(["GEO.ch1.Z.lift_active", "GEO.ch1.path_velocity", "GEO.cycle"])
        plc.write_by_name("PLC.ch1.override", 1200, pyads.PLCTYPE_UINT)
        plc.write_list_by_name({"PLC.ch1.feed_hold": True, "PLC.ch1.override": 1000})
        attr = pyads.NotificationAttrib(1, trans_mode=pyads.ADSTRANS_SERVERONCHA, cycle_time=10)
        handles = plc.add_device_notification("GEO.ch1.Z.lift_active", attr, lambda *a: None)
        time.sleep(0.05)
        h.set(lift_active=True)
        time.sleep(0.05)
        plc.del_device_notification(*handles)
        with contextlib.suppress(pyads.ADSError):
            plc.read(0x121301, 0x30097, pyads.PLCTYPE_BOOL)  # → 0x703
        plc.close()
        time.sleep(0.1)
    out = Path(__file__).with_name("pyads.hex")
    lines = [f"{tag} {frame.hex()}" for tag, frame in log]
    header = "# pyads 3.6.0 ↔ liftd, captured by tests/golden/ads/capture.py"
    out.write_text("\n".join([header, *lines]) + "\n")
    print(f"{out}: {len(lines)} frames")


if __name__ == "__main__":
    main()
