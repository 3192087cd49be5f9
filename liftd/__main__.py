"""`python -m liftd` is the same as the `liftd` console script."""

from __future__ import annotations

import sys

from liftd.cli import main

sys.exit(main())
