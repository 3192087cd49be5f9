"""The IPO acceleration monitor of the lift axis: P-AXIS-00441 (warning) and P-AXIS-00442
(error) as a share of exceedance of a_max.

The levels are a_max·(1 + P-AXIS-00441/1000) and a_max·(1 + P-AXIS-00442/1000) (the parameters
are "percentage exceedance of the maximum axis acceleration" in 0.1 %; both 0 switch the
monitor off; docs/reference/isg-cnc.md §3.4, https://infosys.beckhoff.com/content/1033/
tf5200_axis_parameter/117563787.html and …/117565323.html). The acceleration is measured the
way a drive sees the command positions: the second finite difference over the GEO cycle.

liftd reports an exceedance (event on entering a level, counts, the largest ratio) and does
not stop the channel: the point of path-based Lifting's monitor in this emulator is to show
the overload the method causes, not to hide it.
"""

from __future__ import annotations

from liftd.cnc.params import AxisParams

INF = float("inf")


class AccelMonitor:
    NONE = 0
    WARNING = 1
    ERROR = 2

    def __init__(self, axis: AxisParams, cycle: float) -> None:
        self.a_max = axis.a_max
        off = axis.dyn_a_warn <= 0.0 and axis.dyn_a_err <= 0.0
        self.warn_ratio = INF if off or axis.dyn_a_warn <= 0.0 else 1.0 + axis.dyn_a_warn
        self.err_ratio = INF if off or axis.dyn_a_err <= 0.0 else 1.0 + axis.dyn_a_err
        self.inv_dt2 = 1.0 / (cycle * cycle)
        self.z1 = self.z2 = 0.0
        self.samples = 0
        self.ratio = 0.0  # |a| / a_max of the last sample
        self.level = self.NONE
        self.warning_cycles = 0
        self.error_cycles = 0

    def sample(self, z: float) -> int:
        """Add the command position of one cycle; returns the level if it was entered in this
        cycle (WARNING or ERROR), else NONE."""
        if self.samples >= 2:
            a = (z - 2.0 * self.z1 + self.z2) * self.inv_dt2
            self.ratio = abs(a) / self.a_max
        self.samples += 1
        self.z2, self.z1 = self.z1, z
        if self.samples < 3:
            self.z2 = z if self.samples == 1 else self.z2
            return self.NONE
        level = self.NONE
        if self.ratio > self.err_ratio:
            level = self.ERROR
            self.error_cycles += 1
        elif self.ratio > self.warn_ratio:
            level = self.WARNING
            self.warning_cycles += 1
        entered = level if level > self.level else self.NONE
        self.level = level
        return entered
