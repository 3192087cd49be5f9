"""The real-time side of `liftd run`: the GEO loop process (`geo_loop`, started as
`python -m liftd.runtime`), its supervision from the daemon (`geo_process`), the shared-memory
hand-over (`shared`, `shm`, `records`), the PLC inputs it applies, its timing policy (`cycle`)
and RT settings (`rt`).

May import the core `liftd.cnc`; nothing of ADS, objects, settings or the service. The GEO
process itself loads no numpy, pydantic, structlog, asyncio or pyads (tests/unit/test_layers.py).
"""

# The GEO process's per-cycle part (the loop, its PLC inputs, timing, records and shared-memory
# hand-over) compiled with mypyc by `make` like the core's cycle (liftd.cnc.COMPILED,
# tools/compile_core.py): interpreted, it cost about twice the compiled step in every cycle.
# Not compiled: `loop_config` (pickled over the control pipe; mypyc's classes do not pickle),
# `shared` (its spec is pickled too), `rt` (ctypes, once per cycle) and the daemon's side.
COMPILED: tuple[str, ...] = (
    "liftd.runtime.cycle",
    "liftd.runtime.geo_loop",
    "liftd.runtime.plc_inputs",
    "liftd.runtime.records",
    "liftd.runtime.shm",
)
