"""The CNC object catalogue of the GEO port (ISG addressing, types, symbols) and its ADS
`ObjectProvider`, which adapts a published GEO cycle to ADS bytes.

May import `liftd.ads` (the provider protocol, errors) and the core `liftd.cnc` (snapshot,
params, units); nothing of the runtime, the service or settings.
"""
