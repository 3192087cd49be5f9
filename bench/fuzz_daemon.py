"""Black-box fuzzing of a running `liftd run` over every surface its ADS side has (issue 41),
with the daemon's own budgets ([ads] defaults but the frame cap of ATTACK_ADS-like 64 KiB):

* `reads` — Read/ReadWrite with huge and random lengths to every reserved index group, the
  CNC objects, handles, symbol and data-type uploads;
* `sums` — every sum command (0xF080…0xF086) with random sub-commands and lengths up to 4 GiB;
* `notify` — notification sums on the symbol upload from connections that then stop reading;
* `routing` — a client that registers an AMS port and stalls, another flooding it;
* `plc` — sum writes of the PLC objects (START/STOP/RESET, override, feed hold) in bursts;
* `garbage` — random bytes, cut frames, lying lengths, router commands (closed and reopened);
* `udp` — random datagrams and discovery requests to the UDP port.

Meanwhile a well-behaved client reads `lift_active` back to back (its latency per second), the
daemon's RSS is sampled every 50 ms, and the daemon's log is searched for tracebacks. Prints one
JSON line per surface and a summary line: frames sent, RSS growth (peak − before) against
`budget_bytes`, the probe's p99 (whole run and worst second), GEO deadlines missed, tracebacks.

Run: .venv/bin/python bench/fuzz_daemon.py [--frames 10000000] [--seed 1]   (~15 min for 10⁷)
"""

# `# fmt: skip` where it stays: ruff's one-item-per-line layout of those statements would
# take this file past the house's ~450 lines a file (the others were removed, issue 40)
from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing as mp
import os
import random
import socket
import struct
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.synchronize import Event
from pathlib import Path
from typing import cast

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from liftd.ads import wire  # noqa: E402
from liftd.ads.client import RawClient  # noqa: E402
from liftd.ads.wire import net_id_bytes  # noqa: E402
from liftd.runtime.geo_process import rss_mb  # noqa: E402
from tests.support.daemon import Daemon, write_config  # noqa: E402

ADS = {"max_frame_bytes": 65536, "udp_discovery": True, "udp_port": 0, "max_connections_per_ip": 64}
LIFT = (0x121301, 0x30095)
RESERVED = [0xF003, 0xF004, 0xF005, 0xF006, 0xF007, 0xF008, 0xF009, 0xF00B, 0xF00C, 0xF00D,
            0xF00E, 0xF00F, 0xF011, 0xF100, *range(0xF080, 0xF087)]  # fmt: skip
OBJECTS = [0x121301, 0x21301, 0x121401, 0x121302, 0x120101, 0x23900, 0x123900, 0x4020, 0]
LENGTHS = [0, 1, 2, 4, 8, 1000, 65536, 1 << 20, 256 << 20, 2 << 30, 0xFFFFFFF0, 0xFFFFFFFF]
SOURCE = bytes([10, 9, 8, 7, 1, 1])
POOL = 4096  # distinct frames per surface, sent in random order
BASELINE_S = 30.0  # the probe alone before the attack: its p99 and the GEO loop's misses
SURFACES = ("reads", "sums", "plc", "garbage", "reads-unread", "notify-stalled",
            "routing-stalled", "udp")  # fmt: skip


class Frames:
    def __init__(self, net: bytes, rng: random.Random) -> None:
        self.net, self.rng, self.invoke = net, rng, 0

    def frame(self, command: int, payload: bytes, port: int = 551, flags: int = 4) -> bytes:
        self.invoke = (self.invoke + 1) & 0xFFFFFFFF
        h = wire.AmsHeader(self.net, port, SOURCE, 30000, command, flags, 0, 0, self.invoke)
        return wire.encode_frame(h, payload)

    def ig(self) -> int:
        return self.rng.choice([*RESERVED, *OBJECTS, self.rng.getrandbits(32)])

    def length(self) -> int:
        return self.rng.choice([*LENGTHS, self.rng.getrandbits(32)])

    def read(self) -> bytes:
        r = self.rng
        if r.random() < 0.5:
            return self.frame(2, struct.pack("<III", self.ig(), r.getrandbits(32) if r.random() < 0.3
                                             else LIFT[1], self.length()))  # fmt: skip
        name = r.choice([b"GEO.ch1.Z.lift_active", b"GEO.cycle", b"PLC.ch1.override", b"x"])
        ig = r.choice([0xF003, 0xF004, 0xF007, 0xF009, 0xF011])
        return self.frame(9, struct.pack("<IIII", ig, 0, self.length(), len(name)) + name)

    def sum(self) -> bytes:
        r = self.rng
        ig = r.randrange(0xF080, 0xF087)
        n = r.choice([1, 2, 10, 100, 500, 1000, 1001])
        if ig == 0xF085:
            entry = struct.pack("<IIIIII16s", r.choice([0xF00B, *LIFT[:1]]), 0, self.length(),
                                r.choice([3, 4]), 0, r.choice([1, 10_000]), bytes(16))  # fmt: skip
            body = entry * n
        elif ig == 0xF086:
            body = b"".join(struct.pack("<I", r.getrandbits(8)) for _ in range(n))
        elif ig == 0xF082:
            name = b"GEO.ch1.Z.lift_active"
            body = (struct.pack("<IIII", 0xF003, 0, self.length(), len(name)) * n) + name * n
        elif ig == 0xF081:
            body = struct.pack("<III", *LIFT, 1) * n + bytes(n)
        else:
            body = b"".join(struct.pack("<III", self.ig(), LIFT[1], self.length())
                            for _ in range(min(n, 50))) * max(1, n // 50)  # fmt: skip
            n = len(body) // 12
        rlen = r.choice([0, 8 * n, 0xFFFFFFFF, self.length()])
        return self.frame(9, struct.pack("<IIII", ig, n, rlen, len(body)) + body)

    def plc(self, addresses: list[tuple[int, int]]) -> bytes:
        r = self.rng
        n = r.choice([1, 16, 128, 256])
        subs = [r.choice(addresses) for _ in range(n)]
        heads = b"".join(struct.pack("<III", ig, io, 2) for ig, io in subs)
        data = b"".join(struct.pack("<H", r.choice([0, 1, 500, 1000, 2000])) for _ in subs)
        return self.frame(9, struct.pack("<IIII", 0xF081, n, 4 * n, len(heads + data)) + heads
                          + data)  # fmt: skip

    def garbage(self) -> bytes:
        r = self.rng
        kind = r.randrange(5)
        if kind == 0:
            return r.randbytes(r.randrange(1, 200))
        if kind == 1:
            return self.frame(2, struct.pack("<III", *LIFT, 1))[: r.randrange(1, 40)]
        if kind == 2:  # AMS length ≠ TCP length
            f = bytearray(self.frame(2, struct.pack("<III", *LIFT, 1)))
            f[26:30] = struct.pack("<I", r.getrandbits(32))
            return bytes(f)
        if kind == 3:  # a frame announced above the cap
            return struct.pack("<HI", 0, r.choice([70000, 1 << 30, 0xFFFFFFFF])) + bytes(50)
        return struct.pack(
            "<HI", r.choice([0x1000, 0x0001, 0x1002, 0x1001, 0x4321]), 2
        ) + r.randbytes(2)


class Attacker(threading.Thread):
    """One surface: sends batches on connections it reopens when the daemon closes them."""

    def __init__(self, name: str, d: Daemon, make: Callable[[Frames], bytes], share: int,
                 seed: int, drain: bool = True) -> None:  # fmt: skip
        super().__init__(name=name, daemon=True)
        self.d, self.make, self.share, self.drain = d, make, share, drain
        self.frames = Frames(net_id_bytes(d.net_id), random.Random(seed))
        self.sent = 0
        self.closed = 0
        self.stop = False
        # a pool built once: the attacker's own CPU would otherwise be most of the machine's
        self.pool = [make(self.frames) for _ in range(POOL)]
        self.rng = random.Random(seed)

    def connect(self) -> socket.socket:
        s = socket.create_connection(("127.0.0.1", self.d.port), timeout=5)
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        s.settimeout(0.0)
        return s

    def run(self) -> None:
        s = self.connect()
        while not self.stop and self.sent < self.share:
            batch = self.rng.choices(self.pool, k=64)
            data = b"".join(batch)
            try:
                view = memoryview(data)
                end = time.monotonic() + 2.0
                while view and time.monotonic() < end:
                    try:
                        view = view[s.send(view) :]
                    except BlockingIOError:
                        self._read(s)
                        time.sleep(0.0005)
                self.sent += len(batch)
                if self.drain:
                    self._read(s)
                if view:  # the daemon stopped reading us: start over
                    raise ConnectionError
            except (OSError, ConnectionError):
                self.closed += 1
                s.close()
                s = self.connect()
        s.close()

    @staticmethod
    def _read(s: socket.socket) -> None:
        try:
            while s.recv(1 << 20):
                pass
        except (BlockingIOError, InterruptedError):
            pass


class Stalled(threading.Thread):
    """Connections that subscribe to large notifications (or register a port and are routed
    to) and then read nothing; reopened when the daemon closes them."""

    def __init__(self, d: Daemon, routed: bool, seed: int) -> None:
        super().__init__(daemon=True)
        self.d, self.routed = d, routed
        self.frames = Frames(net_id_bytes(d.net_id), random.Random(seed))
        self.sent = self.closed = 0
        self.stop = False

    def run(self) -> None:
        f = self.frames
        while not self.stop:
            try:
                c = RawClient(self.d.port, net_id_bytes(self.d.net_id), rcvbuf=4096)
                if self.routed:
                    c.send(struct.pack("<HIH", 0x1000, 2, 0))
                    head = b""
                    while len(head) < 14:
                        head += c.sock.recv(14 - len(head))
                    port = struct.unpack_from("<H", head, 12)[0]
                    sender = RawClient(self.d.port, net_id_bytes(self.d.net_id))
                    big = f.frame(3, bytes(60_000), port=port)
                    while not self.stop and not gone(c.sock):
                        sender.sock.settimeout(2.0)
                        sender.send(big * 8)
                        self.sent += 8
                        sender.sock.setblocking(False)
                        Attacker._read(sender.sock)  # the answers once the port is gone
                    sender.close()
                else:
                    n = 512
                    entry = struct.pack("<IIIIII16s", 0xF00B, 0, 0xFFFFFFFF, 3, 0, 10_000,
                                        bytes(16))  # fmt: skip
                    c.send(f.frame(9, struct.pack("<IIII", 0xF085, n, 8 * n, 40 * n) + entry * n))
                    self.sent += 1
                    c.closed_by_server(20.0)
                self.closed += 1
                c.close()
            except OSError:
                self.closed += 1


class Quiet(Daemon):
    """The daemon, keeping only the log lines the bench reads: the PLC surface's millions of
    writes are a geo.plc_input line each, and the GEO task's events a line each."""

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            if ('"event": "geo.' in line and "geo.fault" not in line) or '"lift.' in line:
                continue
            self.raw.append(line)
            with contextlib.suppress(ValueError):
                self.logs.append(json.loads(line))


def gone(sock: socket.socket) -> bool:
    """Whether the daemon closed this connection without reading from it: it aborts, and the
    reset sets the socket's error (unread data stays readable before it, so a peek cannot
    tell)."""
    return sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR) != 0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=10_000_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--surfaces", default=",".join(SURFACES),
                    help="comma-separated, of: " + ", ".join(SURFACES))  # fmt: skip
    args = ap.parse_args()
    surfaces = set(args.surfaces.split(","))
    with tempfile.TemporaryDirectory() as tmp:
        # SCHED_FIFO for the GEO loop where permitted, as the attack table runs it
        cfg = write_config(Path(tmp), program={"repeat": True}, ads=ADS,
                           rt={"sched_fifo_priority": 80})  # fmt: skip
        d = Quiet(cfg)
        try:
            d.ready()
            udp = d.event("ads.udp_listening")
            assert udp is not None
            run(d, int(udp["port"]), args.frames, args.seed, surfaces)
        finally:
            d.stop()


def plc_addresses(port: int, net: str) -> list[tuple[int, int]]:
    c = RawClient(port, net_id_bytes(net))
    out = []
    for name in ("PLC.ch1.start", "PLC.ch1.stop", "PLC.ch1.reset", "PLC.ch1.override",
                 "PLC.ch1.feed_hold", "PLC.ch1.m_ack"):  # fmt: skip
        raw = name.encode()
        reply = c.request(9, struct.pack("<IIII", 0xF007, 0, 12, len(raw)) + raw)
        code, data = wire.decode_read_response(reply.payload)
        if code == 0:
            out.append(struct.unpack_from("<II", data))
    c.close()
    return out


class _Target:
    """What a child process needs of the daemon (a Daemon object does not cross processes)."""

    def __init__(self, port: int, net_id: str) -> None:
        self.port, self.net_id = port, net_id


def attack(port: int, net: str, udp_port: int, total: int, seed: int, surfaces: set[str],
           out: mp.Queue[list[dict[str, object]]], stop: Event) -> None:  # fmt: skip
    """The attackers of every surface, in a process of their own, at the lowest priority: on
    a network they would be other hosts; here they share the 2 vCPUs with the daemon and the
    probe, and their own CPU would otherwise be what the probe measures."""
    os.nice(19)
    d = cast(Daemon, _Target(port, net))
    addresses = plc_addresses(port, net)
    share = total // 6
    attackers = [a for a in (
        Attacker("reads", d, Frames.read, share, seed),
        Attacker("sums", d, Frames.sum, share, seed + 1),
        Attacker("plc", d, lambda f: f.plc(addresses), share // 4, seed + 2),
        Attacker("garbage", d, Frames.garbage, share, seed + 3),
        Attacker("reads-unread", d, Frames.read, share, seed + 4, drain=False),
    ) if a.name in surfaces]  # fmt: skip
    stalled = [s for s in (Stalled(d, False, seed + 5), Stalled(d, True, seed + 6))
               if ("notify-stalled", "routing-stalled")[s.routed] in surfaces]  # fmt: skip
    for t in [*attackers, *stalled]:
        t.start()
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rng = random.Random(seed + 7)
    discovery = bytes.fromhex("03661471000000000100000000000000000000000000000000000000")
    udp_sent = 0
    end = time.monotonic() + 60.0  # with no attacker of frames: a minute of the others
    while (any(a.is_alive() for a in attackers) if attackers else time.monotonic() < end) \
            and not stop.is_set():  # fmt: skip
        for _ in range(50 if "udp" in surfaces else 0):
            data = (rng.randbytes(rng.randrange(1, 400)) if rng.random() < 0.7
                    else discovery[: rng.randrange(8, 28)])  # fmt: skip
            udp.sendto(data, ("127.0.0.1", udp_port))
            udp_sent += 1
        time.sleep(0.01)
    for t in [*attackers, *stalled]:
        t.stop = True
    for t in stalled:
        t.join(25)
    rows: list[dict[str, object]] = [
        {"surface": a.name, "frames": a.sent, "reconnects": a.closed} for a in attackers
    ]
    rows += [
        {"surface": ("notify-stalled", "routing-stalled")[s.routed], "frames": s.sent,
         "closed_by_budget": s.closed}
        for s in stalled
    ]  # fmt: skip
    rows.append({"surface": "udp", "frames": udp_sent})
    out.put(rows)


def probe(port: int, net: str, out: mp.Queue[dict[str, object]], stop: Event) -> None:
    """A well-behaved client in a process of its own: reads lift_active back to back."""
    c = RawClient(port, net_id_bytes(net), timeout_s=30.0)
    lat: list[tuple[float, float]] = []
    t_start = time.monotonic()
    while not stop.is_set():
        t0 = time.perf_counter()
        code, _ = c.read(*LIFT, 1)
        assert code == 0, hex(code)
        lat.append((time.monotonic() - t_start, time.perf_counter() - t0))
    c.close()
    seconds: dict[int, list[float]] = {}
    for t, v in lat:
        seconds.setdefault(int(t), []).append(v)
    p99s = [sorted(v)[int(0.99 * (len(v) - 1))] for v in seconds.values() if v]
    every = sorted(v for _, v in lat)
    out.put({"probe_reads": len(lat),
             "probe_p99_ms": round(1e3 * every[int(0.99 * (len(every) - 1))], 2),
             "probe_max_ms": round(1e3 * every[-1], 2),
             "probe_worst_second_p99_ms": round(1e3 * max(p99s), 2),
             "probe_seconds_over_10ms": sum(p > 0.010 for p in p99s)})  # fmt: skip


@dataclass
class Attacked:
    """What the daemon went through while an attacker process ran beside the probe."""

    rows: list[dict[str, object]]  # the attacker's, one per surface
    probe: dict[str, object]  # the probe's figures under attack
    seconds: float
    alive: bool
    rss_before_mb: float
    rss_peak_mb: float
    geo_exceeded: int  # -1: the daemon died


def baseline(d: Daemon, bench: str, seconds: float = BASELINE_S) -> dict[str, object]:
    """The probe alone for `seconds` (the baseline of the same run), printed as a JSON line."""
    ctx = mp.get_context("spawn")
    stop = ctx.Event()
    q: mp.Queue[dict[str, object]] = ctx.Queue()
    alone = ctx.Process(target=probe, args=(d.port, d.net_id, q, stop))
    exceeded0 = d.read_exceeded()
    alone.start()
    time.sleep(seconds)
    stop.set()
    base = q.get(timeout=60)
    alone.join(10)
    base["geo_exceeded_per_min"] = round((d.read_exceeded() - exceeded0) * 60 / seconds, 1)
    print(json.dumps({"bench": bench, "surface": "none (baseline)", "seconds": seconds, **base}),
          flush=True)  # fmt: skip
    return base


def under_attack(d: Daemon, target: Callable[..., None], args: tuple[object, ...]) -> Attacked:
    """`target(*args, results, stop)` in a process of its own (it puts its rows in `results`
    and ends by itself or when `stop` is set) while the probe reads and the daemon's RSS is
    sampled every 50 ms."""
    ctx = mp.get_context("spawn")
    rss0 = rss_mb(d.proc.pid) or 0.0
    exceeded0 = d.read_exceeded()
    stop = ctx.Event()
    results: mp.Queue[list[dict[str, object]]] = ctx.Queue()
    probed: mp.Queue[dict[str, object]] = ctx.Queue()
    prober = ctx.Process(target=probe, args=(d.port, d.net_id, probed, stop))
    attacker = ctx.Process(target=target, args=(*args, results, stop))
    t_start = time.monotonic()
    prober.start()
    attacker.start()
    peak = rss0
    while attacker.is_alive():
        peak = max(peak, rss_mb(d.proc.pid) or 0.0)
        attacker.join(0.05)
    stop.set()
    rows = results.get(timeout=60)
    summary = probed.get(timeout=60)
    prober.join(10)
    alive = d.proc.poll() is None
    return Attacked(rows, summary, time.monotonic() - t_start, alive, rss0, peak,
                    d.read_exceeded() - exceeded0 if alive else -1)  # fmt: skip


def run(d: Daemon, udp_port: int, total: int, seed: int, surfaces: set[str]) -> None:
    budget = 48 << 20  # [ads] budget_bytes default
    time.sleep(1.0)
    baseline(d, "fuzz_daemon")
    a = under_attack(d, attack, (d.port, d.net_id, udp_port, total, seed, surfaces))
    for row in a.rows:
        print(json.dumps({"bench": "fuzz_daemon", **row}), flush=True)
    frames = sum(int(cast(int, r["frames"])) for r in a.rows)
    wall = a.seconds
    events = Counter(str(r.get("event")) for r in list(d.logs)
                     if str(r.get("event", "")).startswith("ads."))  # fmt: skip
    print(json.dumps({
        "bench": "fuzz_daemon", "surface": "all", "frames": frames, "seconds": round(wall),
        "frames_per_s": round(frames / wall), "daemon_alive": a.alive,
        "rss_before_mb": round(a.rss_before_mb, 1), "rss_peak_mb": round(a.rss_peak_mb, 1),
        "rss_growth_mb": round(a.rss_peak_mb - a.rss_before_mb, 1), "budget_mb": budget >> 20,
        **a.probe, "geo_exceeded": a.geo_exceeded,
        "geo_exceeded_per_min": round(a.geo_exceeded * 60 / wall, 1),
        "tracebacks": sum("Traceback" in line for line in d.raw),
        "protocol_errors": d.count("ads.protocol_error") + d.count("ads.handler_failed"),
        "log_events": dict(events.most_common(12)),
    }), flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
