"""`python -m liftd.runtime CONTROL_FD SHM_FD`: the GEO process, as the daemon's
`GeoProcess` starts it. Its exit status tells the daemon only whether it stopped on request."""

from __future__ import annotations

import sys

from liftd.runtime.geo_loop import main

if __name__ == "__main__":
    control_fd, shm_fd = (int(arg) for arg in sys.argv[1:3])
    sys.exit(0 if main(control_fd, shm_fd) else 1)
