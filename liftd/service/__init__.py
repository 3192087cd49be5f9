"""The daemon side of `liftd run`: composition root (`daemon`), ADS configuration, logging,
metrics, systemd notification and the trace recorder that drains the GEO process's ring.

May import every layer below it (`ads`, `objects`, `runtime`, `settings`, `cnc`, `sim.trace`);
nothing imports it but the CLI.
"""
