"""Headless Chromium for the live view's tests: Debian's `chromium` (`.ci/run` installs it)
driven by Playwright with `executable_path`; no browser is downloaded. Skips with the reason
where either is missing."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

CHROMIUM = "/usr/bin/chromium"
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def chromium_version() -> str:
    out = subprocess.run(
        [CHROMIUM, "--version"], capture_output=True, text=True, timeout=30, check=False
    )
    return out.stdout.strip()


@contextmanager
def browser() -> Iterator[Any]:
    """A Playwright Chromium browser on a fresh user-data dir."""
    if shutil.which(CHROMIUM) is None:
        pytest.skip(f"no {CHROMIUM}: `.ci/run` installs Debian's chromium (as root)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="pip install playwright")
    with (
        tempfile.TemporaryDirectory(prefix="liftd-chromium-") as profile,
        sync_api.sync_playwright() as p,
    ):
        ctx = p.chromium.launch_persistent_context(
            profile,
            executable_path=CHROMIUM,
            headless=True,
            args=FLAGS,
            viewport={"width": 1400, "height": 1000},
        )
        try:
            yield ctx
        finally:
            ctx.close()


# records every data-value change of the elements of one symbol: [Date.now(), value], each
# value it took (a callback gets several changes at once: each one's value is the next one's
# oldValue, the last one's the element's current)
OBSERVE = """(symbol) => {
  window.__changes = [];
  const seen = new WeakSet();
  const watch = () => {
    for (const el of document.querySelectorAll(`[data-symbol="${symbol}"]`)) {
      if (seen.has(el)) continue;
      seen.add(el);
      window.__changes.push([Date.now(), el.dataset.value]);
      new MutationObserver((recs) => {
        const now = Date.now();
        recs.forEach((r, i) => window.__changes.push(
          [now, i + 1 < recs.length ? recs[i + 1].oldValue : el.dataset.value]));
      }).observe(el, {attributes: true, attributeOldValue: true, attributeFilter: ["data-value"]});
    }
  };
  watch();
  new MutationObserver(watch).observe(document.body, {childList: true, subtree: true});
}"""

# records the text of the elements of one symbol at every animation frame (what is painted)
PAINTED = """(symbol) => {
  window.__painted = [];
  const tick = () => {
    const el = document.querySelector(`span[data-symbol="${symbol}"]`);
    const text = el ? el.textContent : null;
    const last = window.__painted[window.__painted.length - 1];
    if (!last || last[1] !== text) window.__painted.push([performance.now(), text]);
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
}"""
