"""Programs that talk to a running liftd over ADS: the simulated PLC (`plc`, pyads) and the
health probe (`healthcheck`, raw AMS/TCP).

May import `liftd.ads` (client side), `liftd.cnc.plc` (schedules) and pyads; nothing of the
daemon or the runtime.
"""
