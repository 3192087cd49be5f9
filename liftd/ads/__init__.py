"""ADS/AMS protocol: sans-IO codec, framer, services and notifications; `server.py` is the only
module with sockets. Knows nothing about the CNC (it serves an `ObjectProvider`).

Imports nothing of liftd outside `liftd.ads`.
"""
