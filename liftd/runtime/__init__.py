"""The real-time side of `liftd run`: the GEO loop process (`geo_loop`, started as
`python -m liftd.runtime`), its supervision from the daemon (`geo_process`), the shared-memory
hand-over (`shared`, `shm`, `records`), the PLC inputs it applies, its timing policy (`cycle`)
and RT settings (`rt`).

May import the core `liftd.cnc`; nothing of ADS, objects, settings or the service. The GEO
process itself loads no numpy, pydantic, structlog, asyncio or pyads (tests/unit/test_layers.py).
"""
