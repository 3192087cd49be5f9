"""`liftd plc`: a simulated PLC. It connects to the GEO port the way a TwinCAT PLC does (AMS/ADS
over TCP, through pyads and Beckhoff's AdsLib), reads `lift_active`/`lift_suppressed` and the
channel state once per PLC cycle with one sum read, prints every transition with a timestamp,
and can write override and feed-hold schedules (the `simulate` SPEC syntax).

`run` raises PlcError when the daemon cannot be reached or a read or write fails — a PLC that
silently shows stale data is worse than one that stops (the CLI maps it to its exit code).
AdsLib's own log lines ("Info: connection closed by remote", "Warning: Socket(): connect
failed") are switched off: the terminal shows liftd's messages only.
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import datetime as dt
import json
import math
import signal
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any, TextIO

import pyads

from liftd.cnc.plc import Schedule

STATE_NAMES = {0: "-", 1: "INIT", 2: "IDLE", 3: "READY", 4: "ACTIVE", 5: "HOLD", 6: "ERROR"}
ADS_RUN = 5
# AdsLib/pyads error codes that mean "nobody answers" rather than "the daemon refused"
# (docs/reference/ads.md §5; 0x274C/0x274D are the WSA codes AdsLib reports on Linux too).
_UNREACHABLE = {0x6, 0x7, 0x745, 0x746, 0x748, 0x274C, 0x274D}


@dataclasses.dataclass(frozen=True, slots=True)
class Target:
    host: str
    tcp_port: int
    net_id: str
    ams_port: int
    channel: int
    axis: str

    @property
    def address(self) -> str:
        return f"{self.host}:{self.tcp_port}"

    def symbols(self) -> dict[str, str]:
        """Short label → symbol name, in the order of the sum read."""
        ch = f"GEO.ch{self.channel}"
        return {
            f"{self.axis}.lift_active": f"{ch}.{self.axis}.lift_active",
            f"{self.axis}.lift_suppressed": f"{ch}.{self.axis}.lift_suppressed",
            "state": f"{ch}.state",
            "line": f"{ch}.line",
            "override": f"{ch}.override",
            "feed_hold": f"{ch}.feed_hold",
            "error_id": f"{ch}.error_id",
            "m_pending": f"{ch}.m_pending",
        }


# AdsLib's log threshold (`size_t Logger::logLevel`: 0 verbose, 1 info, 2 warning, 3 error; it
# prints to stderr from C++); pyads offers no call for it
ADSLIB_LOG_LEVEL = "_ZN6Logger8logLevelE"
ADSLIB_SILENT = 4


def quiet_adslib() -> bool:
    """Switch AdsLib's own logging off; False where this AdsLib build has no such knob."""
    lib: ctypes.CDLL | None = getattr(pyads.pyads_ex, "_adsDLL", None)
    if lib is None:
        return False
    try:
        ctypes.c_size_t.in_dll(lib, ADSLIB_LOG_LEVEL).value = ADSLIB_SILENT
    except ValueError:  # no such symbol in this build
        return False
    return True


# the values whose changes are printed; line/override are context
WATCHED = ("lift_active", "lift_suppressed", "state", "feed_hold", "error_id")
WATCHED_M_ACK = (*WATCHED, "m_pending")  # when this PLC acknowledges (`m_ack = "plc"`)


class PlcError(Exception):
    """The daemon cannot be reached, or a read/write failed: the message says which."""


def _describe(exc: Exception, target: Target, what: str) -> str:
    code = getattr(exc, "err_code", None)
    where = f"liftd at {target.address} (AMS NetId {target.net_id}, port {target.ams_port})"
    if code in _UNREACHABLE:
        return (
            f"cannot reach {where} ({exc}). Is `liftd run` (or `make run`) running, and do "
            "--host/--net-id match its [ads] settings?"
        )
    return f"{what} failed on {where}: {exc}"


class Plc:
    """One PLC: a pyads connection, the symbols it polls and the schedule it writes."""

    def __init__(
        self,
        target: Target,
        schedule: Schedule,
        timeout_ms: int,
        start: bool = False,
        m_ack_delay: float | None = None,
    ) -> None:
        self.target = target
        # acknowledge each pending M function this long after it appeared (`[plc] m_ack =
        # "plc"`: the GEO loop waits for the PLC); None: the loop's own PLC does it
        self.m_ack_delay = m_ack_delay
        self.m_since: tuple[int, float] | None = None  # (M number, first seen), not yet acked
        self.watched = WATCHED if m_ack_delay is None else WATCHED_M_ACK  # what it prints
        self.schedule = schedule
        self.conn = pyads.Connection(target.net_id, target.ams_port, target.address)
        self.timeout_ms = timeout_ms
        self.labels = target.symbols()
        self.written: dict[str, Any] = {}
        self.found: dict[str, Any] = {}  # the levels as this PLC found them, restored at exit
        self.start_pending = start

    def open(self) -> tuple[str, int]:
        """Connect and check the device; returns (device name, ADS state)."""
        try:
            self.conn.open()
            self.conn.set_timeout(self.timeout_ms)
            name, _version = self.conn.read_device_info()
            state, _device = self.conn.read_state()
        except (pyads.ADSError, RuntimeError, OSError) as exc:
            raise PlcError(_describe(exc, self.target, "connecting")) from None
        for symbol in self.labels.values():  # name the symbol a wrong --axis/-c leads to
            try:
                self.conn.get_symbol(symbol)
            except (pyads.ADSError, RuntimeError, OSError) as exc:
                raise PlcError(_describe(exc, self.target, f"looking up {symbol}")) from None
        ch = f"PLC.ch{self.target.channel}"
        levels = [f"{ch}.override"] * bool(self.schedule.override)
        levels += [f"{ch}.feed_hold"] * bool(self.schedule.feed_hold)
        if levels:
            try:
                found = self.conn.read_list_by_name(levels)
            except (pyads.ADSError, RuntimeError, OSError) as exc:
                raise PlcError(_describe(exc, self.target, "reading the PLC levels")) from None
            for symbol, value in found.items():
                if isinstance(value, str):  # a failed sub-read comes back as its error text
                    raise PlcError(f"reading {symbol} failed: {value}")
            self.found = found
        return str(name), int(state)

    def restore(self) -> list[tuple[str, Any]]:
        """Write back the levels (override, feed hold) this PLC changed, as it found them: the
        channel keeps a level until someone writes it (a reload too), so a schedule that ended
        inside a hold would otherwise hold the machine after this PLC has gone."""
        done = []
        for symbol, value in self.found.items():
            if symbol not in self.written or self.written[symbol] == value:
                continue
            plc_type = pyads.PLCTYPE_UINT if symbol.endswith("override") else pyads.PLCTYPE_BOOL
            try:
                self.conn.write_by_name(symbol, value, plc_type)
            except (pyads.ADSError, RuntimeError, OSError) as exc:
                raise PlcError(_describe(exc, self.target, f"restoring {symbol}")) from None
            self.written[symbol] = value
            done.append((symbol, _plain(value)))
        return done

    def close(self) -> None:
        self.conn.close()

    def read(self) -> dict[str, Any]:
        try:
            values = self.conn.read_list_by_name(list(self.labels.values()))
        except (pyads.ADSError, RuntimeError, OSError) as exc:
            raise PlcError(_describe(exc, self.target, "the sum read")) from None
        out = {}
        for label, symbol in self.labels.items():
            value = values.get(symbol)
            if isinstance(value, str):  # pyads reports a failed sub-read as its error text
                raise PlcError(f"reading {symbol} failed: {value}")
            out[label.split(".")[-1]] = value
        return out

    def write_schedule(self, t: float) -> list[tuple[str, Any]]:
        """Write the scheduled override (0.1 %) and feed hold where they change at time t."""
        ch = f"PLC.ch{self.target.channel}"
        wanted: dict[str, Any] = {}
        sched = self.schedule
        # a level is the schedule's from its first step on: before, it stays as found (an
        # operator's feed hold is not released, nor the override set to 100 %, at t = 0)
        if sched.override and t >= min(step for step, _ in sched.override) - 1e-12:
            wanted[f"{ch}.override"] = round(sched.override_at(t) * 1000)
        if sched.feed_hold and t >= min(t0 for t0, _ in sched.feed_hold) - 1e-12:
            wanted[f"{ch}.feed_hold"] = sched.hold_at(t)
        if self.start_pending:  # NC start: a rising edge on PLC.chN.start, once
            wanted[f"{ch}.start"] = True
            self.start_pending = False
        done = []
        for symbol, value in wanted.items():
            if self.written.get(symbol) == value:
                continue
            plc_type = pyads.PLCTYPE_UINT if symbol.endswith("override") else pyads.PLCTYPE_BOOL
            # recorded before the write: a SIGTERM that lands as the write returns still
            # finds it in `written`, so restore() writes the level back (a start is a command,
            # never deduplicated, and not restored)
            self.written[symbol] = value
            try:
                self.conn.write_by_name(symbol, value, plc_type)
            except (pyads.ADSError, RuntimeError, OSError) as exc:
                raise PlcError(_describe(exc, self.target, f"writing {symbol}")) from None
            finally:
                if symbol.endswith(".start"):
                    self.written.pop(symbol, None)
            done.append((symbol, value))
        return done

    def acknowledge(self, t: float, m_pending: int) -> list[tuple[str, Any]]:
        """The PLC's part of a synchronised M function: TRUE on PLC.chN.m_ack once the M
        function has been pending for the delay, once per M function."""
        if self.m_ack_delay is None or m_pending < 0:
            self.m_since = None
            return []
        if self.m_since is None or self.m_since[0] != m_pending:
            self.m_since = (m_pending, t)
        number, since = self.m_since
        if since < 0.0 or t - since < self.m_ack_delay - 1e-9:
            return []  # acknowledged already (since < 0), or not yet due
        symbol = f"PLC.ch{self.target.channel}.m_ack"
        try:
            self.conn.write_by_name(symbol, True, pyads.PLCTYPE_BOOL)
        except (pyads.ADSError, RuntimeError, OSError) as exc:
            raise PlcError(_describe(exc, self.target, f"writing {symbol}")) from None
        self.m_since = (number, -1.0)
        return [(symbol, 1)]


def _fmt(label: str, value: Any) -> str:
    if label == "state":
        return f"{value} {STATE_NAMES.get(int(value), '?')}"
    if isinstance(value, bool):
        return str(int(value))
    return str(value)


class Printer:
    def __init__(self, out: TextIO, as_json: bool, axis: str) -> None:
        self.out, self.as_json, self.axis = out, as_json, axis

    def transition(self, t_rel: float, label: str, old: Any, new: Any, v: dict[str, Any]) -> None:
        now = dt.datetime.now(dt.UTC)
        name = f"{self.axis}.{label}" if label.startswith("lift_") else label
        if self.as_json:
            rec = {
                "time": now.isoformat(timespec="milliseconds"),
                "t": round(t_rel, 4),
                "object": name,
                "from": _plain(old),
                "to": _plain(new),
                "line": v["line"],
                "state": v["state"],
            }
            print(json.dumps(rec), file=self.out, flush=True)
            return
        stamp = now.astimezone().strftime("%H:%M:%S.%f")[:-3]
        change = f"{_fmt(label, old) if old is not None else '-'} -> {_fmt(label, new)}"
        print(
            f"{stamp}  +{t_rel:8.3f} s  {name:<18} {change:<16} line {v['line']:<5} "
            f"override {v['override'] / 10:.1f} %",
            file=self.out,
            flush=True,
        )

    def wrote(self, t_rel: float, symbol: str, value: Any) -> None:
        if self.as_json:
            print(
                json.dumps({"t": round(t_rel, 4), "write": symbol, "value": _plain(value)}),
                file=self.out,
                flush=True,
            )
        else:
            print(
                f"{'':12}  +{t_rel:8.3f} s  write {symbol} = {_plain(value)}",
                file=self.out,
                flush=True,
            )


def _plain(value: Any) -> Any:
    return int(value) if isinstance(value, bool) else value


def poll(
    plc: Plc,
    printer: Printer,
    cycle_s: float,
    duration_s: float | None,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> dict[str, Any]:
    """The PLC cycle: write due schedule values, sum-read, print changes. Returns counters."""
    t0 = clock()
    watched = plc.watched
    last: dict[str, Any] = dict.fromkeys(watched)
    cycles = transitions = late = 0
    k = 0
    while duration_s is None or clock() - t0 < duration_s:
        t_rel = clock() - t0
        values = plc.read()  # a PLC cycle: inputs first, then the outputs it computes
        cycles += 1
        for label in watched:
            if values[label] != last[label]:
                printer.transition(t_rel, label, last[label], values[label], values)
                transitions += last[label] is not None
                last[label] = values[label]
        for symbol, value in plc.write_schedule(t_rel) + plc.acknowledge(
            t_rel, values["m_pending"]
        ):
            printer.wrote(t_rel, symbol, value)
        k += 1
        wait = t0 + k * cycle_s - clock()
        if wait > 0:
            sleep(wait)
        else:  # a PLC task that overran: keep the grid, count it
            late += 1
            k = max(k, math.ceil((clock() - t0) / cycle_s))
    return {"cycles": cycles, "transitions": transitions, "late_cycles": late}


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


ENDING_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@contextlib.contextmanager
def signals_ignored() -> Iterator[None]:
    """Ctrl-C, SIGTERM and SIGHUP ignored inside (an operator's second Ctrl-C cannot cut the
    restore of the levels short), their handlers as before after it."""
    previous = {signum: signal.signal(signum, signal.SIG_IGN) for signum in ENDING_SIGNALS}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def run(
    target: Target,
    schedule: Schedule,
    cycle_ms: float,
    duration_s: float | None,
    as_json: bool,
    timeout_ms: int = 1000,
    start: bool = False,
    out: TextIO = sys.stdout,
    m_ack_delay: float | None = None,
) -> None:
    """Poll until the duration ends, Ctrl-C, SIGTERM or SIGHUP. Raises PlcError."""
    quiet_adslib()
    plc = Plc(target, schedule, timeout_ms, start, m_ack_delay)
    # a supervisor's or `timeout`'s SIGTERM (and a closed terminal's SIGHUP) ends it as Ctrl-C
    # does: the levels it set are written back (before, the hold outlived it)
    before = {
        signum: signal.signal(signum, _interrupt) for signum in (signal.SIGTERM, signal.SIGHUP)
    }
    printer = Printer(out, as_json, target.axis)
    t0 = time.monotonic()
    try:
        name, state = plc.open()
        if not as_json:
            print(
                f"connected to {name} at {target.address}, AMS NetId {target.net_id} port "
                f"{target.ams_port}; polling {', '.join(plc.labels.values())} every "
                f"{cycle_ms:g} ms",
                file=out,
                flush=True,
            )
        if state != ADS_RUN:
            print(
                f"liftd plc: warning: ADS state {state}, not RUN (5): the GEO task is not cycling",
                file=sys.stderr,
            )
        counters = poll(plc, printer, cycle_ms * 1e-3, duration_s)
    except KeyboardInterrupt:
        counters = None
    finally:
        restored: list[tuple[str, Any]] = []
        with signals_ignored():
            try:
                restored = plc.restore()
            except PlcError as exc:  # the daemon went away: nothing left to hold
                print(f"liftd plc: warning: {exc}", file=sys.stderr)
            finally:
                plc.close()
        for signum, handler in before.items():  # as the caller had them
            signal.signal(signum, handler)
        with contextlib.suppress(OSError):  # all restored first, even when stdout has gone
            for symbol, value in restored:
                printer.wrote(time.monotonic() - t0, symbol, value)
    if counters is not None and not as_json:
        print(
            f"{counters['cycles']} PLC cycles, {counters['transitions']} transitions, "
            f"{counters['late_cycles']} late cycles",
            file=out,
        )


def parse_host(text: str, default_port: int) -> tuple[str, int]:
    """HOST or HOST:PORT → (host, port)."""
    host, sep, port = text.rpartition(":")
    if not sep:
        return text, default_port
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"--host {text!r}: PORT must be 1..65535")
    return host, int(port)
