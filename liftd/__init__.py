"""liftd: emulator of the TwinCAT 3 CNC GEO task for collision avoidance by lifting."""

from __future__ import annotations

__version__ = "0.1.0"
