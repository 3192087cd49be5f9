"""The live view in a real browser (headless Chromium, Playwright) against `liftd run` and
`liftd view`: lift_active follows the GEO task as pyads sees it, the override slider reaches
GEO.ch1.override, the refused cases, and the trace replay."""

from __future__ import annotations

import csv
import http.server
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pyads
import pytest

from tests.support.browser import OBSERVE, PAINTED, browser
from tests.support.daemon import Daemon
from tests.support.paths import REPO
from tests.support.ui import liftd_view, ui_daemon, ui_url

# wall-clock latencies asserted: run alone, after the parallel part of `make test`
pytestmark = [pytest.mark.integration, pytest.mark.timing]
TOKEN = "browser-test-token-0123"
LIFT = "GEO.ch1.Z.lift_active"


@pytest.fixture(scope="module")
def daemon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Daemon]:
    d = ui_daemon(tmp_path_factory.mktemp("uib"), hops=True, control=True, token=TOKEN)
    yield d
    d.stop()


def _poll(d: Daemon, seconds: float, out: list[tuple[float, bool]]) -> None:
    plc = pyads.Connection(d.net_id, 551, d.address)
    plc.open()
    try:
        last = None
        end = time.time() + seconds
        while time.time() < end:
            v = bool(plc.read_by_name(LIFT, pyads.PLCTYPE_BOOL))
            if v != last:
                out.append((time.time(), v))
                last = v
            time.sleep(0.005)  # a PLC task of 5 ms
    finally:
        plc.close()


def test_lift_active_follows_the_geo_task_within_100_ms_of_pyads(daemon: Daemon) -> None:
    """TRUE and FALSE each seen, every change pyads sees (polling every 5 ms, a PLC task)
    shown in the page's data-value, in order and close behind."""
    with browser() as ctx:
        page = ctx.new_page()
        page.goto(ui_url(daemon))
        page.wait_for_selector("body[data-ready=true]")
        page.evaluate(OBSERVE, LIFT)
        seen: list[tuple[float, bool]] = []
        poller = threading.Thread(target=_poll, args=(daemon, 6.0, seen))
        poller.start()
        poller.join(60)
        changes = page.evaluate("window.__changes")
    plc = seen[1:]  # the first read is the state, not a change
    assert {v for _, v in plc} == {True, False}, seen
    shown = [(t / 1000.0, v == "true") for t, v in changes[1:]]
    lags = []
    for t_plc, v in plc:
        match = next((t for t, w in shown if w == v and t >= t_plc - 0.05), None)
        assert match is not None, (t_plc, v, shown)
        lags.append(match - t_plc)
    # every change shown, in order; the 100 ms as a median and for 9 in 10: on this shared VM
    # (load 8-10 on 2 vCPUs) the daemon's event loop itself stalls 100-300 ms now and then
    # (a plain WebSocket client sees them too: bench/bench_ui.py), which no page can hide
    shown_lags = [round(x, 3) for x in lags]
    assert sorted(lags)[len(lags) // 2] <= 0.1, shown_lags
    assert sum(x <= 0.1 for x in lags) >= 0.9 * len(lags), shown_lags
    assert max(lags) <= 1.0, shown_lags


def test_the_override_slider_reaches_the_geo_task(daemon: Daemon) -> None:
    with browser() as ctx:
        page = ctx.new_page()
        page.goto(ui_url(daemon))
        page.wait_for_selector("body[data-ready=true]")
        assert page.locator(".control").is_visible()
        assert page.locator(".control.locked").count() == 1  # until the token is given
        page.fill(".control .token", TOKEN)
        page.click(".control .auth button")
        page.wait_for_selector(".control:not(.locked)")
        page.eval_on_selector(
            '[data-symbol="PLC.ch1.override"]',
            "el => { el.value = 450; el.dispatchEvent(new Event('input')); }",
        )
        end = time.monotonic() + 10
        while daemon.read_symbol("GEO.ch1.override_requested", "<H") != 450:
            assert time.monotonic() < end
            time.sleep(0.05)
        page.wait_for_selector('[data-symbol="GEO.ch1.override_requested"][data-value="450"]')
        page.eval_on_selector(
            '[data-symbol="PLC.ch1.override"]',
            "el => { el.value = 1000; el.dispatchEvent(new Event('input')); }",
        )
        page.wait_for_selector('[data-symbol="GEO.ch1.override_requested"][data-value="1000"]')


WRITE_WITHOUT_TOKEN = """(url) => new Promise((resolve) => {
  const ws = new WebSocket(url);
  ws.onmessage = (e) => { const m = JSON.parse(e.data);
    if (m.op === "hello") ws.send(JSON.stringify({op: "write", id: 1, symbol: "PLC.ch1.stop", value: true}));
    if (m.op === "result") resolve(m); };
  setTimeout(() => resolve({timeout: true}), 8000);
})"""


def test_refused_without_token_and_from_a_foreign_origin(daemon: Daemon, tmp_path: Path) -> None:
    url = ui_url(daemon)
    ws_url = url.replace("http://", "ws://") + "ws"
    (tmp_path / "index.html").write_text(f"""<!doctype html><script>
      window.result = new Promise((resolve) => {{
        const ws = new WebSocket("{ws_url}");
        ws.onmessage = () => resolve("message");
        ws.onclose = (e) => resolve("closed " + e.code);
      }});</script>""")
    handler = lambda *a, **k: http.server.SimpleHTTPRequestHandler(  # noqa: E731
        *a, directory=str(tmp_path), **k
    )
    other = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=other.serve_forever, daemon=True).start()
    try:
        with browser() as ctx:
            page = ctx.new_page()
            page.goto(url)
            page.wait_for_selector("body[data-ready=true]")
            result = page.evaluate(WRITE_WITHOUT_TOKEN, ws_url)
            assert result["ok"] is False and "token" in result["detail"]
            foreign = ctx.new_page()
            foreign.goto(f"http://127.0.0.1:{other.server_address[1]}/index.html")
            assert foreign.evaluate("window.result") == "closed 1006"  # 403 at the handshake
    finally:
        other.shutdown()
    assert daemon.read_symbol("GEO.ch1.state", "<I") != 5  # no STOP reached the channel


def test_control_disabled_shows_no_control(tmp_path: Path) -> None:
    d = ui_daemon(tmp_path)
    try:
        with browser() as ctx:
            page = ctx.new_page()
            page.goto(ui_url(d))
            page.wait_for_selector("body[data-ready=true]")
            assert page.locator(".control").count() == 0
            assert "read only" in page.inner_text("#control-state")
            result = page.evaluate(WRITE_WITHOUT_TOKEN, ui_url(d).replace("http", "ws") + "ws")
            assert result["ok"] is False and "read only" in result["detail"]
    finally:
        d.stop()


def _first_lift(trace: Path) -> float:
    with trace.open() as f:
        for row in csv.DictReader(f):
            if row["lift_active"] == "1":
                return float(row["t"])
    raise AssertionError("no lift in the trace")


def test_liftd_view_replays_a_trace(tmp_path: Path) -> None:
    trace = tmp_path / "demo.csv"
    config = str(REPO / "config" / "liftd.toml")
    demo = str(REPO / "config" / "programs" / "demo.nc")
    subprocess.run(
        [sys.executable, "-m", "liftd", "simulate", demo, "-c", config, "--trace", str(trace)],
        check=True,
        capture_output=True,
        timeout=120,
    )
    with liftd_view(trace, config) as url, browser() as ctx:
        page: Any = ctx.new_page()
        page.goto(url)
        page.wait_for_selector("body[data-ready=true][data-mode=trace]")
        assert page.locator("#timeline").is_visible()
        assert page.get_attribute(f'[data-symbol="{LIFT}"]', "data-value") == "false"
        assert (
            page.get_attribute('[data-symbol="GEO.timing.lateness_max_us"]', "data-missing")
            == "true"
        )
        t_lift = _first_lift(trace)
        t1 = float(page.inner_text("#clock").split("/")[1].split()[0])
        page.eval_on_selector(
            "#scrub",
            f"el => {{ el.value = {round(1000 * t_lift / t1) + 2};"
            " el.dispatchEvent(new Event('input')); }",
        )
        page.wait_for_selector(f'[data-symbol="{LIFT}"][data-value="true"]', timeout=10000)
        page.click("#play")
        cycle = '[data-symbol="GEO.cycle"]'
        before = page.get_attribute(cycle, "data-value")
        end = time.monotonic() + 10  # (no wait_for_function: the page's CSP forbids eval)
        while page.get_attribute(cycle, "data-value") == before:
            assert time.monotonic() < end
            page.wait_for_timeout(50)


# the columns of the Z plot shaded as a lift (its translucent red over most of the height)
SHADED = """() => {
  const cv = document.querySelector('.zt'), W = cv.width, H = cv.height;
  const d = cv.getContext('2d').getImageData(0, 0, W, H).data;
  let cols = 0;
  for (let x = 0; x < W; x++) {
    let n = 0;
    for (let y = 0; y < H; y++) {
      const i = 4 * (y * W + x);
      if (d[i + 3] > 10 && d[i + 3] < 40 && d[i] > d[i + 1] + 50) n++;
    }
    if (n > H / 2) cols++;
  }
  return cols;
}"""


def _one_cycle_trace(path: Path, length: int = 1, row: int = 1500, rows: int = 3000) -> None:
    """A trace of 3 s (1 ms rows) whose lift_active is TRUE in `length` rows from `row`."""
    axes = ["x", "y", "z"]
    with path.open("w") as f:
        f.write(",".join(["t", "line", *axes, "v_path", "override", "lift_active"]))
        f.write(",lift_suppressed\n")
        for i in range(rows):
            on = "1" if row <= i < row + length else "0"
            f.write(f"{i * 1e-3:.4f},12,{i * 0.01:.3f},0,1,100,1,{on},0\n")


@pytest.mark.parametrize("length", [1, 10])
def test_a_lift_of_one_geo_cycle_is_painted_true_then_false(tmp_path: Path, length: int) -> None:
    """Review #7: the feed pulses a one-cycle range as TRUE and FALSE in one update; the page
    paints the TRUE (for ~150 ms), then the FALSE, and shades the Z plot for it. A range
    shorter than an update (20 ms) may straddle two, its FALSE in the update after its
    TRUE's (a one-row range now and then, a ten-row range about every second run): the TRUE
    is held as long."""
    trace = tmp_path / "one.csv"
    _one_cycle_trace(trace, length)
    config = str(REPO / "config" / "liftd.toml")
    with liftd_view(trace, config) as url, browser() as ctx:
        page: Any = ctx.new_page()
        page.goto(url)
        page.wait_for_selector("body[data-ready=true][data-mode=trace]")
        page.eval_on_selector(  # to 1.2 s, 0.3 s before the lift
            "#scrub", "el => { el.value = 400; el.dispatchEvent(new Event('input')); }"
        )
        end = time.monotonic() + 10
        while not page.inner_text("#clock").startswith("1.2"):
            assert time.monotonic() < end, page.inner_text("#clock")
            page.wait_for_timeout(20)
        page.evaluate(OBSERVE, LIFT)
        page.evaluate(PAINTED, LIFT)
        page.click("#play")
        count = '[data-symbol="GEO.ch1.Z.lift_count"]'
        while page.get_attribute(count, "data-value") != "1":
            assert time.monotonic() < end + 10
            page.wait_for_timeout(50)
        page.wait_for_timeout(400)
        changes = page.evaluate("window.__changes")
        painted = page.evaluate("window.__painted")
        shaded = page.evaluate(SHADED)
    values = [v for _, v in changes]
    assert values[0] == "false" and values[1:3] == ["true", "false"], changes
    texts = [t for _, t in painted]
    assert "TRUE" in texts and texts[-1] == "FALSE", painted
    on = next(i for i, (_, t) in enumerate(painted) if t == "TRUE")
    assert painted[on + 1][0] - painted[on][0] >= 100, painted  # shown, not a flicker
    assert shaded > 0  # the Z plot's lift shading
