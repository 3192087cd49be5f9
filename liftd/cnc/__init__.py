"""Pure GEO core: NC decoder, path preparation, interpolator, lift generators, the automatic PLC.

No IO, no clock, no logging, no threads; SI units inside (`units` is the only place with unit
factors). Imports nothing of liftd outside `liftd.cnc`.

`COMPILED` names the modules of the GEO cycle that `make` compiles to C extensions with mypyc
(`tools/compile_core.py`, docs/geo-core.md "The compiled core"): the same source, 3× less
CPU per cycle, bit-identical results. Without a C compiler they run as Python.
"""

# The cycle's path: everything `GeoTask.step` and `Machine.step` run, and the automatic PLC of
# `simulate`. Not compiled: preparation (nc/, geo_program, the lists). Tests that inject ruckig
# failures patch `lift/profile.py` in the core run as Python (tests/support/pure_core.py).
COMPILED: tuple[str, ...] = (
    "liftd.cnc.actions",
    "liftd.cnc.batch",
    "liftd.cnc.channel_state",
    "liftd.cnc.events",
    "liftd.cnc.geo_task",
    "liftd.cnc.lift_ahead",
    "liftd.cnc.machine",
    "liftd.cnc.plc",
    "liftd.cnc.release",
    "liftd.cnc.ruckig1",
    "liftd.cnc.runs",
    "liftd.cnc.lift.advanced",
    "liftd.cnc.lift.controller",
    "liftd.cnc.lift.guard",
    "liftd.cnc.lift.monitor",
    "liftd.cnc.lift.motion",
    "liftd.cnc.lift.path_based",
    "liftd.cnc.lift.profile",
    "liftd.cnc.path.bounds",
    "liftd.cnc.path.aims",
    "liftd.cnc.path.brakes",
    "liftd.cnc.path.constraints",
    "liftd.cnc.path.geometry",
    "liftd.cnc.path.interpolator",
    "liftd.cnc.path.limits",
    "liftd.cnc.path.nominal",
    "liftd.cnc.path.plan",
    "liftd.cnc.path.program",
    "liftd.cnc.path.shift",
    "liftd.cnc.path.table",
    "liftd.cnc.path.profiles",
    "liftd.cnc.path.targets",
    "liftd.cnc.path.tracker",
    "liftd.cnc.path.velocity",
)
