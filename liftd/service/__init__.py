"""The daemon side of `liftd run`: the composition root (`daemon`), the GEO events as log lines
(`geo_log`), ADS configuration (`adsconfig`), logging (`logs`), Prometheus metrics (`metrics`),
systemd notification and the reload control socket (`systemd`, `control`), the trace
recorder that drains the GEO process's ring (`trace_recorder`) and the live view's host
(`ui_host`).

May import every layer below it: `liftd.ads`, `liftd.objects`, `liftd.runtime`,
`liftd.settings`, the core `liftd.cnc`, `liftd.sim` (the trace CSV writer) and `liftd.ui` (the
live view); nothing imports it but the CLI.
"""
