"""The daemon side of `liftd run`: the composition root (`daemon`), the GEO events as log lines
(`geo_log`), ADS configuration (`adsconfig`), logging (`logs`), Prometheus metrics (`metrics`),
systemd notification and the reload control socket (`systemd`, `control`) and the trace
recorder that drains the GEO process's ring (`trace_recorder`).

May import every layer below it: `liftd.ads`, `liftd.objects`, `liftd.runtime`,
`liftd.settings`, the core `liftd.cnc` and `liftd.sim` (the trace CSV writer); nothing imports
it but the CLI.
"""
