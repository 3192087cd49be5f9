"""The server's refusal rules as functions: which Host and Origin headers pass."""

from __future__ import annotations

import pytest

from liftd.ui.web import host_allowed, origin_allowed


@pytest.mark.parametrize(
    ("host", "ok"),
    [
        ("127.0.0.1:8551", True), ("localhost:8551", True), ("[::1]:8551", True),
        ("10.1.2.3", True), ("LOCALHOST", True), ("cnc-bench:8551", True),
        ("evil.example:8551", False), ("127.0.0.1.nip.io:8551", False), ("", False),
        ("[::1", False),
    ],
)  # fmt: skip
def test_host_is_an_ip_localhost_or_a_configured_name(host: str, ok: bool) -> None:
    assert host_allowed(host, ("cnc-bench",)) is ok


@pytest.mark.parametrize(
    ("origin", "ok"),
    [
        (None, True), ("http://127.0.0.1:8551", True), ("http://127.0.0.1:8552", False),
        ("http://evil.example", False), ("https://127.0.0.1:8551", False), ("null", False),
    ],
)  # fmt: skip
def test_origin_is_the_page_itself(origin: str | None, ok: bool) -> None:
    assert origin_allowed(origin, "127.0.0.1:8551") is ok
