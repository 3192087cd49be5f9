"""The live view against a running `liftd run` (WebSocket client, no browser): what the page
gets, the control round trip through the ADS write path, the refused cases, and the endpoint
fuzzed (malformed and oversized messages, 200 connections, a page that never reads) while the
ADS server and the GEO loop go on."""

from __future__ import annotations

import asyncio
import contextlib
import json
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import aiohttp
import pytest

from tests.support.daemon import Daemon, write_config
from tests.support.paths import REPO
from tests.support.replay import WRITES, first_difference, simulate_logged_writes
from tests.support.ui import (
    QUIET_RT,
    liftd_view,
    never_reading,
    open_page,
    run,
    ui_daemon,
    ui_url,
)

pytestmark = pytest.mark.integration
TOKEN = "ui-test-token-0123456789"


def _daemon(tmp: Path, **ui: object) -> Daemon:
    return ui_daemon(tmp, max_connections=16, **ui)


@pytest.fixture(scope="module")
def daemon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Daemon]:
    d = _daemon(tmp_path_factory.mktemp("ui"), control=True, token=TOKEN)
    yield d
    d.stop()


def test_the_page_and_its_files_come_from_liftd_with_a_csp(daemon: Daemon) -> None:
    url = ui_url(daemon)
    with urllib.request.urlopen(url, timeout=10) as r:
        html = r.read().decode()
        csp = r.headers["Content-Security-Policy"]
    assert "default-src 'none'" in csp and "script-src 'self'" in csp
    assert "frame-ancestors 'none'" in csp and "unsafe-inline" not in csp
    assert 'src="/static/app.js"' in html and "http" not in html.split("<body>")[0]
    for name in ("app.js", "style.css"):
        with urllib.request.urlopen(url + "static/" + name, timeout=10) as r:
            assert re.search(r"https?://|//[a-z0-9.-]+\.[a-z]{2,}/", r.read().decode()) is None
    req = urllib.request.Request(url, headers={"Host": "rebound.example:8551"})
    with pytest.raises(urllib.error.HTTPError) as exc:
        urllib.request.urlopen(req, timeout=10)
    assert exc.value.code == 421


def test_hello_has_every_object_and_updates_follow(daemon: Daemon) -> None:
    async def go() -> None:
        page = await open_page(ui_url(daemon))
        symbols = {o["symbol"] for o in page.hello["objects"]}
        assert {
            "GEO.ch1.Z.lift_active",
            "GEO.ch1.Z.lift_count",
            "GEO.timing.lateness_max_us",
            "GEO.ads.connections",
            "PLC.ch1.override",
        } <= symbols
        first = page.values["GEO.cycle"]
        end = time.monotonic() + 5
        while page.values["GEO.cycle"] == first and time.monotonic() < end:
            await page.receive()
        assert page.values["GEO.cycle"] > first
        assert page.hello["control"]["enabled"] is True
        await page.close()

    run(go())


async def _drawing_version(url: str) -> int:
    """The drawing's version a page is told (in its hello, or a frame once it is built)."""
    page = await open_page(url)
    assert '"path"' not in json.dumps(page.hello)
    version = page.hello["state"]["x"]["geometry"][0]
    end = time.monotonic() + 60
    while version is None:
        assert time.monotonic() < end, "no drawing"
        m = await page.receive()
        for f in m.get("frames", []):
            version = (f.get("x") or {}).get("geometry", [version])[0]
    await page.close()
    return int(version)


def test_the_drawing_is_fetched_by_version_and_not_in_the_hello(daemon: Daemon) -> None:
    """Built once after ready, encoded once: a page GETs it by the version its hello or a
    frame names; an old or unknown version is 404."""
    url = ui_url(daemon)

    version = run(_drawing_version(url))
    with urllib.request.urlopen(f"{url}drawing/0/{version}", timeout=10) as r:
        drawing = json.loads(r.read())
        assert r.headers["Content-Security-Policy"]
    assert drawing["channel"] == 1 and len(drawing["path"]) > 10 and drawing["ranges"]
    for bad in (f"drawing/0/{version + 1}", "drawing/9/1", "drawing/0/x"):
        with pytest.raises(urllib.error.HTTPError) as exc:
            urllib.request.urlopen(url + bad, timeout=10)
        assert exc.value.code == 404, bad


def test_a_long_program_is_drawn_in_a_process_of_its_own(tmp_path: Path) -> None:
    """Over THREAD_MAX_CHARS (1 500 hops: ~115 KB) the drawing comes from a spawned process."""
    d = ui_daemon(tmp_path, hops=1500)
    try:
        url = ui_url(d)
        version = run(_drawing_version(url))
        with urllib.request.urlopen(f"{url}drawing/0/{version}", timeout=10) as r:
            drawing = json.loads(r.read())
        assert drawing["error"] is None and len(drawing["path"]) > 3000 and drawing["ranges"]
    finally:
        d.stop()


def test_a_foreign_origin_is_refused(daemon: Daemon) -> None:
    async def go() -> None:
        with pytest.raises(aiohttp.WSServerHandshakeError) as exc:
            await open_page(ui_url(daemon), origin="http://evil.example")
        assert exc.value.status == 403

    run(go())


def test_control_needs_the_token(daemon: Daemon) -> None:
    async def go() -> None:
        page = await open_page(ui_url(daemon))
        await page.send({"op": "write", "id": 1, "symbol": "PLC.ch1.override", "value": 300})
        r = await page.reply("result")
        assert r["ok"] is False and "token" in r["detail"]
        for n in range(3):
            await page.send({"op": "auth", "token": f"guess-{n}"})
        replies = [await page.reply("auth") for _ in range(3)]
        assert [r["ok"] for r in replies] == [False, False, False]
        closed = await page.reply("closed")
        assert closed["code"] == 1008  # three wrong tokens close the connection
        await page.close()
        assert daemon.read_symbol("GEO.ch1.override_requested", "<H") != 300

    run(go())


def test_control_round_trip_and_bad_values(daemon: Daemon) -> None:
    async def go() -> None:
        page = await open_page(ui_url(daemon))
        await page.send({"op": "auth", "token": TOKEN})
        assert (await page.reply("auth"))["ok"] is True
        for i, (symbol, value, code) in enumerate(
            [
                ("PLC.ch1.override", 5000, "0x706"),
                ("PLC.ch1.override", True, "0x706"),
                ("PLC.ch1.feed_hold", 1, "0x706"),
                ("GEO.ch1.line", 3, "only PLC"),
                ("PLC.ch1.nothing", 1, "0x710"),
                ("PLC.ch1.override", "x", "value"),
                ("PLC.ch1.override", 1.5, "value"),
                (7, 1, "symbol"),
            ]
        ):
            await page.send({"op": "write", "id": i, "symbol": symbol, "value": value})
            r = await page.reply("result")
            assert r["ok"] is False and code in r["detail"], (symbol, value, r)
        await page.send({"op": "write", "id": 99, "symbol": "PLC.ch1.override", "value": 650})
        assert (await page.reply("result"))["ok"] is True
        end = time.monotonic() + 5
        while page.values.get("GEO.ch1.override_requested") != 650 and time.monotonic() < end:
            await page.receive()
        assert page.values["GEO.ch1.override_requested"] == 650  # the GEO task took it
        assert daemon.read_symbol("GEO.ch1.override_requested", "<H") == 650  # ADS sees it
        await page.send({"op": "write", "id": 100, "symbol": "PLC.ch1.override", "value": 1000})
        assert (await page.reply("result"))["ok"] is True
        await page.close()

    run(go())


def test_fuzz_malformed_oversized_and_many(daemon: Daemon) -> None:
    url = ui_url(daemon)

    async def go() -> None:
        page = await open_page(url)
        for bad in [
            "",
            "{",
            "[]",
            "null",
            '{"op": 5}',
            '{"op": "zz"}',
            '{"op":"seek","t":1}',
            '{"op": "write", "id": "x"}',
            '{"op":"auth","token":{}}',
            "\u0000" * 100,
        ]:
            await page.ws.send_str(bad)
            r = (
                await page.reply("error")
                if "auth" not in bad and "write" not in bad
                else (await page.reply("auth" if "auth" in bad else "result"))
            )
            assert r.get("ok") in (None, False), (bad, r)
        await page.ws.send_bytes(b"\x00\x01")
        assert (await page.reply("error"))["detail"] == "binary message"
        await page.ws.send_str("x" * 10_000)  # over max_message_bytes: the page is closed
        assert (await page.reply("closed"))["code"] == 1009
        await page.close()
        idle = []  # 200 TCP connections that never send a request
        for _ in range(200):
            s = socket.create_connection(("127.0.0.1", int(url.rsplit(":", 1)[1].strip("/"))))
            idle.append(s)
        pages, refused = [], []
        await asyncio.sleep(1.05)  # (the page above was a handshake too)
        for _ in range(200):  # a burst: 10 handshakes a second from one peer, the rest 429
            try:
                pages.append(await open_page(url))
            except aiohttp.WSServerHandshakeError as exc:
                refused.append(exc.status)
        assert set(refused) == {429} and len(pages) == 10, (len(pages), set(refused))
        await asyncio.sleep(1.05)
        while len(pages) < 16:  # at the allowed pace: up to max_connections, then 503
            await asyncio.sleep(0.15)
            pages.append(await open_page(url))
        await asyncio.sleep(0.15)
        with pytest.raises(aiohttp.WSServerHandshakeError) as over:
            await open_page(url)
        assert over.value.status == 503
        # the ADS server and the GEO loop meanwhile
        c0 = daemon.read_symbol("GEO.cycle", "<Q")
        await asyncio.sleep(0.3)
        assert daemon.read_symbol("GEO.cycle", "<Q") > c0
        for p in pages:
            await p.close()
        for s in idle:
            s.close()
        await asyncio.sleep(0.3)
        fresh = await open_page(url)  # and a page opens again
        await fresh.close()

    run(go())


def test_requests_aiohttp_cannot_parse_are_400_and_one_log_line(daemon: Daemon) -> None:
    """A header over 8 KiB, a broken request line: 400, and one `ui.bad_request` per peer and
    second instead of aiohttp's traceback for each (the fuzz of bench/fuzz_ui.py found 30
    tracebacks in 20 s)."""
    port = int(ui_url(daemon).rstrip("/").rsplit(":", 1)[1])
    before = daemon.count("ui.bad_request")
    for request in [b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: " + b"b" * 9000 + b"\r\n\r\n",
                    b"GET /\x00 HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"] * 3:  # fmt: skip
        with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
            s.sendall(request)
            assert s.recv(64).split(b" ")[1] == b"400"
    end = time.monotonic() + 5
    while daemon.count("ui.bad_request") == before and time.monotonic() < end:
        time.sleep(0.05)
    logged = [r for r in daemon.logs if r.get("event") == "ui.bad_request"][before:]
    assert 1 <= len(logged) <= 2 and "LineTooLong" in str(logged[0]["error"])  # within a second
    assert not any("Traceback" in line or "Error handling request" in line for line in daemon.raw)


def test_a_flood_or_a_stream_of_bad_messages_closes_the_page(daemon: Daemon) -> None:
    async def go() -> None:
        page = await open_page(ui_url(daemon))
        for _ in range(25):
            await page.ws.send_str("not json")
        errors = 0
        while (m := await page.receive())["op"] != "closed":
            errors += m["op"] == "error"
        assert (errors, m["code"]) == (21, 1008)  # the 21st refusal, then the close
        await page.close()
        page = await open_page(ui_url(daemon))
        for _ in range(150):  # more than 100 a second (each refused: no token, not malformed)
            await page.ws.send_str('{"op": "write", "symbol": "PLC.ch1.stop", "value": true}')
        results = 0
        while (m := await page.receive())["op"] != "closed":
            results += m["op"] == "result"
        assert m["code"] == 1008 and results <= 100
        await page.close()

    run(go())


def test_a_page_that_never_reads_is_dropped(daemon: Daemon) -> None:
    url = ui_url(daemon)
    sock = never_reading(url)
    peer = "{}:{}".format(*sock.getsockname())

    def dropped() -> bool:
        return any(
            r.get("event") == "ui.page_dropped" and r.get("peer") == peer for r in list(daemon.logs)
        )

    try:
        end = time.monotonic() + 60
        cycles = []
        while not dropped() and time.monotonic() < end:
            cycles.append(daemon.read_symbol("GEO.cycle", "<Q"))  # ADS answers meanwhile
            time.sleep(0.5)
        assert dropped()
        assert cycles == sorted(cycles) and cycles[-1] > cycles[0]
    finally:
        with contextlib.suppress(OSError):
            sock.close()


def test_control_off_is_read_only(tmp_path: Path) -> None:
    d = _daemon(tmp_path)
    try:

        async def go() -> None:
            page = await open_page(ui_url(d))
            assert page.hello["control"]["enabled"] is False
            await page.send({"op": "auth", "token": TOKEN})
            assert (await page.reply("auth"))["ok"] is False
            await page.send({"op": "write", "id": 1, "symbol": "PLC.ch1.stop", "value": True})
            r = await page.reply("result")
            assert r["ok"] is False and "read only" in r["detail"]
            await page.close()

        run(go())
        assert d.read_symbol("GEO.ch1.state", "<I") != 5  # no STOP reached the channel (HOLD)
    finally:
        d.stop()


def test_page_writes_keep_run_trace_equal_to_simulate(tmp_path: Path) -> None:
    """Override and feed hold from the page while `run --trace` records the demo: the loop
    logs the cycle each took effect in (geo.plc_input), and `simulate` with that schedule
    gives the same trace, row for row, as with writes over ADS (test_daemon.py)."""
    cfg = write_config(
        tmp_path, ui={"enabled": True, "port": 0, "control": True, "token": TOKEN}, rt=QUIET_RT
    )
    trace = tmp_path / "run.csv"
    d = Daemon(cfg, "--trace", str(trace))
    try:
        d.ready()

        async def go() -> None:
            page = await open_page(ui_url(d))
            await page.send({"op": "auth", "token": TOKEN})
            assert (await page.reply("auth"))["ok"] is True
            for i, (pause, symbol, value) in enumerate(WRITES):
                await asyncio.sleep(pause)
                await page.send({"op": "write", "id": i, "symbol": symbol, "value": value})
                assert (await page.reply("result"))["ok"] is True
            await page.close()

        run(go())
        assert d.event("geo.program_end", 60) is not None
    finally:
        assert d.stop() == 0
    expected, k_last = simulate_logged_writes(d.logs, cfg, tmp_path)
    got = trace.read_text().splitlines()
    diff = first_difference(got, expected, k_last)
    assert diff is None, (diff, got[diff], expected[diff])


def test_simulate_view_serves_the_runs_trace(tmp_path: Path) -> None:
    cfg = write_config(tmp_path, ui={"port": 0})
    demo = cfg.read_text().split('file = "')[1].split('"')[0]
    proc = subprocess.Popen(
        [sys.executable, "-m", "liftd", "simulate", demo, "-c", str(cfg), "--view"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        url = None
        for line in proc.stdout:  # the run's summary, then the view's address
            if found := re.search(r"liftd view: (http://\S+/)", line):
                url = found.group(1)
                break
        assert url is not None

        async def go() -> None:
            page = await open_page(url)
            assert page.hello["mode"] == "trace" and page.hello["control"]["enabled"] is False
            assert page.hello["state"]["x"]["trace"]["t1"] > 14.0  # the demo's 14.4 s
            await page.close()

        run(go())
    finally:
        proc.terminate()
        assert proc.wait(10) == 0


def test_liftd_view_of_two_channels_and_a_sibling_left_out(tmp_path: Path) -> None:
    """OUT.csv and OUT.ch2.csv of the two-head machine: both channels' symbols; without the
    sibling, channel 2's are null and channel 1 still plays."""
    config = str(REPO / "config" / "liftd-2ch.toml")
    head1 = str(REPO / "config" / "programs" / "two-head" / "head1.nc")
    trace = tmp_path / "t.csv"
    subprocess.run(
        [sys.executable, "-m", "liftd", "simulate", head1, "-c", config, "--trace", str(trace)],
        check=True,
        capture_output=True,
        timeout=120,
    )
    for sibling in (True, False):
        if not sibling:
            (tmp_path / "t.ch2.csv").unlink()
        with liftd_view(trace, config) as url:

            async def go(url: str, sibling: bool = sibling) -> None:
                page = await open_page(url)
                assert [c["id"] for c in page.hello["channels"]] == [1, 2]
                await page.send({"op": "seek", "t": 6.0})
                await page.reply("trace")
                while page.values.get("GEO.cycle") != 6000:
                    await page.receive()
                assert isinstance(page.values["GEO.ch1.X.command_position"], int)
                w = page.values["GEO.ch2.W.command_position"]
                assert isinstance(w, int) if sibling else w is None
                await page.close()

            run(go(url))


def test_a_reload_with_a_new_token_locks_pages_unlocked_with_the_old(tmp_path: Path) -> None:
    """Review #8: the token file rewritten and SIGHUP: the new token applies at once (no
    restart hint), the old one unlocks nothing more, an open page loses control."""
    old, new = "old-token-0123456789", "new-token-9876543210"
    (tmp_path / "ui.token").write_text(old + "\n")
    d = ui_daemon(tmp_path, control=True, token_file="ui.token")
    try:
        url = ui_url(d)

        async def unlocked(token: str) -> Any:
            page = await open_page(url)
            await page.send({"op": "auth", "token": token})
            assert (await page.reply("auth"))["ok"] is True
            return page

        async def auth(token: str) -> bool:
            page = await open_page(url)
            await page.send({"op": "auth", "token": token})
            ok = bool((await page.reply("auth"))["ok"])
            await page.close()
            return ok

        async def go() -> None:
            page = await unlocked(old)
            (tmp_path / "ui.token").write_text(new + "\n")
            d.signal(signal.SIGHUP)
            locked = await page.reply("auth", timeout=30)
            assert locked["ok"] is False and "token changed" in locked["detail"]
            await page.send({"op": "write", "id": 1, "symbol": "PLC.ch1.override", "value": 500})
            assert (await page.reply("result"))["ok"] is False
            await page.close()
            assert await auth(old) is False
            assert await auth(new) is True

        run(go())
        assert d.event("config.reload_accepted") is not None
        assert d.event("config.reload_partial", 0.5) is None
    finally:
        d.stop()
