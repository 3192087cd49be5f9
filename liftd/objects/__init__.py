"""The CNC object catalogue of the GEO port and its ADS `ObjectProvider`."""
