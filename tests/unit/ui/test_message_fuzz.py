"""Whatever a page sends, the server answers with a refusal or a reply of the protocol, never an
exception (which aiohttp would log as a traceback and answer by dropping the page): the message
handler of the live view and of the trace player fuzzed with arbitrary text and JSON, as the
ADS connection is fuzzed (tests/unit/ads/test_connection_fuzz.py)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from liftd.objects.catalog import Catalog
from liftd.ui.player import TraceSession
from liftd.ui.trace import load_traces
from liftd.ui.web import MAX_SYMBOL_CHARS, Refused, Session, UiServer, WebConfig, _Page
from tests.unit.ui.test_feed import CH
from tests.unit.ui.test_trace import write

OPS = ("auth", "write", "seek", "play", "pause", "speed", "hello", "zz", "")


class Log:
    def warning(self, event: str, **kw: object) -> None:
        pass


class Live:
    """The live hub's session as the server sees it: no commands of its own."""

    period = None

    def hello(self) -> dict[str, Any]:
        return {"op": "hello"}

    def take(self) -> list[str] | None:
        return []

    def command(self, msg: dict[str, Any]) -> dict[str, Any] | None:
        return None

    def attach(self, wake: object) -> None:
        pass

    def detach(self, wake: object) -> None:
        pass


written: list[tuple[str, bool | int]] = []


def writer(symbol: str, value: bool | int) -> None:
    if not symbol.startswith("PLC.ch1."):
        raise Refused(f"{symbol[:40]}: not a PLC object")
    written.append((symbol, value))


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=12,
)
messages = st.one_of(
    st.text(max_size=200),  # anything
    st.builds(json.dumps, json_values),  # any JSON
    st.builds(  # objects with an op and fields of any type: the paths past the first check
        lambda op, extra: json.dumps({"op": op, **extra}),
        st.sampled_from(OPS),
        st.dictionaries(st.sampled_from(("token", "symbol", "value", "id", "t", "x")), json_values),
    ),
    st.builds(lambda n: "[" * n + "]" * n, st.integers(1, 2000)),  # nesting within 4 KiB
    st.builds(lambda n: '{"op":"seek","t":' + "[" * n + "]" * n + "}", st.integers(500, 1500)),
    st.sampled_from(
        [
            '{"op":"seek","t":Infinity}',
            '{"op":"seek","t":NaN}',
            '{"op":"seek","t":1e999}',
            '{"op":"speed","x":-Infinity}',
            '{"op":"write","symbol":"PLC.ch1.override","value":1e999}',
            '{"op":"auth","token":"' + "\\ud800" + '"}',
        ]
    ),
)


@pytest.fixture(scope="module")
def trace_session(tmp_path_factory: pytest.TempPathFactory) -> TraceSession:
    path: Path = tmp_path_factory.mktemp("trace") / "t.csv"
    write(path, [(False, False), (True, False), (False, True)])
    return TraceSession(load_traces(Catalog(CH), [str(path)]), [None])


@pytest.mark.parametrize("mode", ["live", "trace"])
@settings(
    max_examples=400, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(texts=st.lists(messages, min_size=1, max_size=6), authed=st.booleans())
def test_every_message_gets_an_answer_of_the_protocol(
    mode: str, trace_session: TraceSession, texts: list[str], authed: bool
) -> None:
    cfg = WebConfig(control=True, token="s3cret", mode=mode)
    server = UiServer(cfg, Live, Log(), writer, lambda ip: "")
    session: Session = Live() if mode == "live" else trace_session
    page = _Page("127.0.0.1")
    page.authed = authed
    for text in texts:
        bad0 = server.counters.bad_messages
        reply = server._message(page, session, text)
        assert reply is not None and isinstance(reply.get("op"), str)
        json.dumps(reply, allow_nan=False)  # what the page gets is strict JSON
        if reply["op"] == "error":
            assert server.counters.bad_messages == bad0 + 1 and reply["detail"]
        elif reply["op"] == "result" and reply["ok"]:
            assert mode == "live" and page.authed
            symbol, value = reply["symbol"], reply["value"]
            assert 0 < len(symbol) <= MAX_SYMBOL_CHARS and isinstance(value, bool | int)
            assert written[-1] == (symbol, value)
        elif reply["op"] == "trace":
            assert mode == "trace"
            pos = trace_session._position()
            assert pos["t0"] <= pos["t"] <= pos["t1"]


def test_deep_nesting_is_a_refusal_not_an_exception() -> None:
    server = UiServer(WebConfig(), Live, Log())
    page = _Page("127.0.0.1")
    reply = server._message(page, Live(), "[" * 2000 + "]" * 2000)
    assert reply == {"op": "error", "detail": "a message is a JSON object with an op"}
    assert page.bad == 1
