"""Pure GEO core: NC decoder, path preparation, interpolator, lift generators.

No IO, no clock, no logging, no threads; SI units inside. Imports nothing of liftd outside
`liftd.cnc` and `liftd.units`.
"""
