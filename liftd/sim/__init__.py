"""`liftd simulate` and what it shows: the GEO core on a virtual clock (`simulate`), the two lift
methods side by side (`compare`), the trace CSV (`trace`) and the figures (`plot`).

May import the core (`liftd.cnc`), numpy and, lazily, matplotlib; nothing of the service,
the runtime or ADS.
"""
