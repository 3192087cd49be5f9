"""The live view in the browser (issue 38): one page that shows the GEO task as it runs
(`liftd run` with `[ui] enabled`) or as a trace recorded it (`liftd view`).

`feed` turns what the ADS provider reads (a `GeoView`) into the page's values, keyed by the
ADS symbol names of the object catalogue, as versioned deltas; `geometry` draws a program's
prepared path and lift ranges for the page; `hub` keeps the live deltas for every open page
and takes the page's control messages; `trace` replays a trace CSV as views; `web` is the
HTTP/WebSocket server (aiohttp) with its security rules; `static/` the page, served by liftd
(nothing from other hosts).

May import the core `liftd.cnc`, `liftd.objects` (the catalogue: symbols, units, getters) and
`liftd.settings`; nothing of the runtime, the service or the ADS protocol. The GEO process
never loads it (tests/unit/test_layers.py).
"""
