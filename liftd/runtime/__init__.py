"""The real-time side of `liftd run`: the GEO loop process and its shared-memory hand-over.
Knows the GEO core, not ADS."""
