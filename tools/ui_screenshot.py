"""docs/ui.png: the live view on the demo, in headless Chromium, while Z lifts (README
"Watching liftd live"). Starts its own daemon on free ports (never 48898 / 8551).

Run: .venv/bin/python tools/ui_screenshot.py [OUT.png]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import pyads  # noqa: E402

from tests.support.browser import browser  # noqa: E402
from tests.support.ui import ui_daemon, ui_url  # noqa: E402


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "ui.png"
    with tempfile.TemporaryDirectory() as tmp:
        d = ui_daemon(Path(tmp), control=True, token="screenshot-token-0123")
        plc = pyads.Connection(d.net_id, 551, d.address)  # a PLC among the ADS connections
        plc.open()
        try:
            plc.read_by_name("GEO.ch1.Z.lift_active", pyads.PLCTYPE_BOOL)
            with browser() as ctx:
                page = ctx.new_page()
                page.set_viewport_size({"width": 1400, "height": 900})
                page.goto(ui_url(d))
                page.wait_for_selector("body[data-ready=true]")
                page.fill(".control .token", "screenshot-token-0123")
                page.click(".control .auth button")
                page.wait_for_selector(".control:not(.locked)")
                time.sleep(15)  # a whole run of the demo in the trail and the Z plot
                page.wait_for_selector(
                    '[data-symbol="GEO.ch1.Z.lift_phase"][data-value="1"]', timeout=30000
                )  # Z rising: a range open
                page.wait_for_timeout(60)
                page.screenshot(path=str(out), full_page=True)
        finally:
            plc.close()
            d.stop()
    print(out)


if __name__ == "__main__":
    main()
