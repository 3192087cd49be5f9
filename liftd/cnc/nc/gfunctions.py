"""The G functions of one NC block: `GFunctions` owns their modal state, the G groups (one of
each per block), motion mode, G90/G91, G161/G162, inch/metric, zero offsets (G53..G59, G92),
tool radius compensation's selection (D, G40/G41/G42, G138/G139, the `trc.Trc` it selects) and
the smoothing liftd accepts and runs unsmoothed. Changes with the G functions liftd emulates;
the modal decoder (`modal.py`), which interprets the rest of a block, holds the same
`GFunctions` as the program decoder does.
"""

from __future__ import annotations

from liftd.cnc import units
from liftd.cnc.nc.blocks import ErrorId, LiftStart, MotionKind, NcFault
from liftd.cnc.nc.context import DecoderContext
from liftd.cnc.nc.report import Report
from liftd.cnc.nc.trc import Trc
from liftd.cnc.nc.words import Words
from liftd.cnc.params import LiftMethod

MOTION_G = {0: MotionKind.RAPID, 1: MotionKind.LINEAR, 2: MotionKind.ARC_CW, 3: MotionKind.ARC_CCW}
# G groups a block holds one of, with the ISG id for a second one (TF5200 diagnosis: 20108
# .../tf5200_diagnosis/250789259.html, 20114 …/250815371, 20118 …/250832779, 20127 …/250871947)
G_GROUPS = {
    **dict.fromkeys((0, 1, 2, 3), ErrorId.MOTION_G_TWICE),
    **dict.fromkeys((40, 41, 42), ErrorId.TRC_G_TWICE),
    **dict.fromkeys((70, 71), ErrorId.UNIT_G_TWICE),
    **dict.fromkeys((161, 162), ErrorId.CENTRE_G_TWICE),
}
MODE_G = frozenset({17, 94, 163})  # XY plane, F in mm/min, radius programming
ZERO_OFFSET_G = {53: 0, 54: 1, 55: 2, 56: 3, 57: 4, 58: 5, 59: 6}
# Smoothing the decoder accepts and runs unsmoothed: G code -> (kind, selects (True) or
# deselects (False)). G61/G261/G260 polynomial contouring, G151/G150 spline (FCT_SPLINE /
# FCT_POLY of P-STUP-00060, vendor §4.2.1; programming manual 206307595).
SMOOTHING_G = {
    61: ("G61 (polynomial contouring)", True),
    261: ("G261 (polynomial contouring)", True),
    260: ("G261 (polynomial contouring)", False),
    151: ("G151 (spline)", True),
    150: ("G151 (spline)", False),
}
SMOOTHING_CMD = {
    "#HSC": "#HSC ON (HSC smoothing)",
    "#SPLINE": "#SPLINE ON",
    "#CONTOUR MODE": "G261 (polynomial contouring)",
}
NO_RADIUS = "G41/G42 without a tool radius (programmed contour)"


class GFunctions:
    """The G functions' part of the modal state; the lift range open (`ModalDecoder.open_lift`)
    is passed in where a G function is refused inside one."""

    def __init__(self, ctx: DecoderContext, report: Report) -> None:
        self.ctx = ctx
        self.report = report
        self.z = ctx.axis_names.index(ctx.lift_axis)  # the configured lift axis
        self.axis_index = {name: k for k, name in enumerate(ctx.axis_names)}
        self.motion = MotionKind.LINEAR
        self.incremental = False
        self.center_absolute = False  # G161 absolute, G162 (default) relative centre
        self.unit = units.M_PER_MM  # G71 (initial); G70: inch
        self.zero_group = ctx.zero_offset_default
        self.g92 = tuple(0.0 for _ in ctx.axis_names)
        self.offset = self._offsets()
        self.trc = Trc()
        self.tool_configured = False  # the active D has a radius in the tool table

    def _offsets(self) -> tuple[float, ...]:
        """The zero offset in effect per axis: the selected group (G53 only with
        P-ZERO-00001) plus the G92 reference point offset."""
        group = self.zero_group
        values = self.ctx.zero_offsets.get(group) if group or self.ctx.g53_offsets else None
        if values is None:
            return self.g92
        return tuple(a + b for a, b in zip(values, self.g92, strict=True))

    def apply(
        self, w: Words, faults: list[NcFault], open_lift: LiftStart | None
    ) -> tuple[bool, bool]:
        """Apply a block's G functions (their faults into `faults`); returns whether the block
        is a dwell (G04) and whether it sets the G92 offset (then `g92` applies its words)."""
        dwell = g92 = False
        groups: set[ErrorId] = set()
        side: int | None = None
        for code, col in w.gcodes:
            twice = G_GROUPS.get(code)
            if twice is not None:
                if twice in groups:
                    message = f"G{code:02d}: a second G function of its group in one block"
                    faults.append(NcFault(twice, col, message + " (the first one counts)"))
                    continue
                groups.add(twice)
            if code in MOTION_G:
                self.motion = MOTION_G[code]
            elif code == 4:
                dwell = True
            elif code in (90, 91):
                self.incremental = code == 91
            elif code in (161, 162):
                self.center_absolute = code == 161
            elif code in (70, 71):
                # G70 inch / G71 metric (TF5200 G-code list, docs/reference/isg-cnc.md §5 [S98])
                self.unit = units.program_length_factor(code == 70)
            elif code in ZERO_OFFSET_G:
                self.zero_group = ZERO_OFFSET_G[code]
                self.offset = self._offsets()
            elif code == 92:
                g92 = True
            elif code in (40, 41, 42):
                side = {40: 0, 41: 1, 42: -1}[code]
            elif code in (138, 139):
                self.trc.direct = code == 138
            elif code in SMOOTHING_G:
                kind, selects = SMOOTHING_G[code]
                fault = self.smoothing(kind, selects, col, open_lift)
                if fault is not None:
                    faults.append(fault)
            elif code not in MODE_G:
                faults.append(
                    NcFault(ErrorId.UNSUPPORTED, col, f"G{code:02d} is not emulated by liftd")
                )
        if side is not None:
            fault = self._select_trc(side, w.gcodes[0][1], open_lift)
            if fault is not None:
                faults.append(fault)
        return dwell, g92

    def smoothing(
        self, kind: str, selects: bool, column: int, open_lift: LiftStart | None
    ) -> NcFault | None:
        """Smoothing is accepted and runs unsmoothed (one warning per kind). Inside a lift
        range no smoothing may be selected (vendor §2.4: "additional contour smoothing of the
        lift axis (contouring, G61/G261, G151, #SPLINE ON, #HSC ON) is not possible in the
        lifting range"); with path-based Lifting not deselected either (§2.2.1: "between
        LIFT_START and LIFT_END smoothing can not be selected or deselected")."""
        if open_lift is not None and (selects or self.ctx.lift_method is LiftMethod.LIFTING):
            what = "selected" if selects else "deselected"
            return NcFault(
                ErrorId.SMOOTHING_IN_LIFT_RANGE,
                column,
                f"{kind.split(' (', 1)[0]}: smoothing {what} inside the lift range started in "
                f"line {open_lift.line} (vendor §2.4)",
            )
        if selects:
            self.report.count(
                kind,
                column,
                f"{kind}: smoothing is not emulated by liftd; the path "
                "runs unsmoothed (exact contour, corners as programmed)",
            )
        return None

    def tool(self, word: tuple[float, int]) -> None:
        """D selects the tool radius for TRC (tool data wz[i].radius, P-TOOL-00004)."""
        number, col = word
        if number != int(number) or number < 0:
            raise NcFault(ErrorId.NUMBER, col, "D needs a tool number >= 0")
        radius = self.ctx.tool_radii.get(int(number))
        self.tool_configured = radius is not None or number == 0
        self.trc.set_radius(radius or 0.0)

    def _select_trc(self, side: int, column: int, open_lift: LiftStart | None) -> NcFault | None:
        if side != 0 and not self.tool_configured and self.trc.side == 0:
            self.report.count(
                NO_RADIUS,
                column,
                "G41/G42: no tool radius configured for the selected "
                "D (liftd.toml [nc.tools] or the ISG tool list): the programmed "
                "contour runs uncompensated",
                ErrorId.TRC_NO_RADIUS,
            )
        if (
            side != 0
            and open_lift is not None
            and self.axis_index.get(open_lift.axis, self.z) in (0, 1)
        ):
            return NcFault(
                ErrorId.TRC_LIFT_AXIS,
                column,
                f"tool radius compensation in the plane of the lift axis {open_lift.axis} "
                f"inside the lift range started in line {open_lift.line} (vendor §2.4)",
            )
        self.trc.set_side(side)
        return None

    def g92_words(self, w: Words) -> None:
        """G92 reference point offset in the programmed axes: absolute under G90, added under
        G91; takes effect with the next absolute coordinate of the axis (programming manual
        https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/206145291.html)."""
        g92 = list(self.g92)
        for k, name in enumerate(self.ctx.axis_names):
            word = w.values.get(name)
            if word is not None:
                value = word[0] * self.unit
                g92[k] = g92[k] + value if self.incremental else value
        self.g92 = tuple(g92)
        self.offset = self._offsets()
