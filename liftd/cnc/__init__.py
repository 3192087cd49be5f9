"""Pure GEO core: NC decoder, path preparation, interpolator, lift generators, the automatic PLC.

No IO, no clock, no logging, no threads; SI units inside (`units` is the only place with unit
factors). Imports nothing of liftd outside `liftd.cnc`.
"""
