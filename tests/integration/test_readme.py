"""The manual's ADS examples (docs/plc.md, once the README's), as a user copies them, against a
running `liftd run`: the pyads snippet executed verbatim (only the daemon's address and NetId
substituted, since tests never use the fixed port 48898), and the TwinCAT ADSREAD snippet's
NETID/PORT/IDXGRP/IDXOFFS/LEN replayed as the same ADS read."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import pyads
import pytest

from tests.support.daemon import Daemon, write_config
from tests.support.paths import REPO

pytestmark = pytest.mark.integration

PAGE = (REPO / "docs" / "plc.md").read_text()  # "Connecting a PLC"
SHIPPED_ADDRESS, SHIPPED_NET_ID = "127.0.0.1:48898", "127.0.0.1.1.1"


def block(lang: str, after: str) -> str:
    """The first fenced block of `lang` after the text `after`."""
    start = PAGE.index(after)
    match = re.search(rf"```{lang}\n(.*?)```", PAGE[start:], re.S)
    assert match is not None, f"no ```{lang} block after {after!r}"
    return match.group(1)


def test_readme_examples_use_the_shipped_endpoint() -> None:
    shipped = (REPO / "config" / "liftd.toml").read_text()
    assert f"port = {SHIPPED_ADDRESS.split(':')[1]}" in shipped
    assert f'net_id = "{SHIPPED_NET_ID}"' in shipped
    assert SHIPPED_ADDRESS in block("python", "**pyads**")
    assert f"'{SHIPPED_NET_ID}'" in block("iecst", "**TwinCAT 3 PLC**")


def test_pyads_and_twincat_snippets_work_against_the_daemon(tmp_path: Path) -> None:
    d = Daemon(write_config(tmp_path, program={"repeat": True}))
    try:
        d.ready()
        code = block("python", "**pyads**")
        code = code.replace(SHIPPED_ADDRESS, d.address).replace(SHIPPED_NET_ID, d.net_id)
        run = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=30, check=False
        )
        assert run.returncode == 0, run.stderr
        assert run.stdout.split() in (
            ["False", "False"],
            ["True", "False"],
            ["True", "True"],
            ["False", "True"],
        )
        assert d.read_symbol("GEO.ch1.override_requested", "<H") == 500  # the snippet's write

        st = block("iecst", "**TwinCAT 3 PLC**")
        fields = dict(re.findall(r"(\w+)\s*:=\s*([^,;]+?)\s*(?:,|\);)", st))
        assert fields["NETID"].strip("'") == SHIPPED_NET_ID and fields["PORT"] == "551"
        group, offset = (
            int(fields[k].replace("16#", "").replace("_", ""), 16) for k in ("IDXGRP", "IDXOFFS")
        )
        assert fields["LEN"] == "SIZEOF(bLiftActive)"  # BOOL: 1 byte
        plc = pyads.Connection(d.net_id, int(fields["PORT"]), d.address)
        plc.open()
        try:
            deadline = time.monotonic() + 20
            seen = set()
            while len(seen) < 2 and time.monotonic() < deadline:  # the demo lifts within 20 s
                seen.add(plc.read(group, offset, pyads.PLCTYPE_BOOL))
                time.sleep(0.01)
            assert seen == {False, True}  # ADSREAD of those numbers follows Z's lift_active
            assert plc.read(group + 0x100, offset, pyads.PLCTYPE_STRING) == "lift_active"
        finally:
            plc.close()
    finally:
        assert d.stop() == 0
