"""`liftd simulate` and `liftd study` and what they show: the GEO core on a virtual clock
(`simulate`), its summary as typed values and their JSON (`summary`), the two lift methods side
by side (`compare`), the trace CSV (`trace`), the figures (`plot`), and the study of a program
library in a process pool (`study`) or on a Dask cluster (`cluster`) with its report (`report`)
and progress bar (`progress`).

May import the core (`liftd.cnc`), numpy and, lazily, matplotlib; distributed in `cluster`
only (the optional `cluster` extra); nothing of the service, the runtime, the settings or ADS
(the study gets the settings as values and a callable from the CLI).
"""

# The per-cycle part of `simulate` (its cycle driver, the trace writer, the summary) compiled
# with mypyc by `make` like the core's cycle (liftd.cnc.COMPILED, tools/compile_core.py).
COMPILED: tuple[str, ...] = (
    "liftd.sim.recorders",
    "liftd.sim.simulate",
    "liftd.sim.summary",
    "liftd.sim.trace",
)
