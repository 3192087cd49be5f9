"""The G functions of one NC block against the decoder's modal state: the G groups (one of each
per block), motion mode, G90/G91, G161/G162, inch/metric, zero offsets (G53..G59, G92), tool
radius compensation's selection (D, G40/G41/G42, G138/G139) and the smoothing liftd accepts
and runs unsmoothed. Changes with the G functions liftd emulates; `ModalDecoder` (modal.py),
which interprets the rest of a block, is built on it.
"""

from __future__ import annotations

from liftd.cnc import units
from liftd.cnc.nc.blocks import ErrorId, LiftStart, MotionKind, NcFault
from liftd.cnc.nc.context import DecoderContext
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
    """The G functions' part of the modal state (set up by `ModalDecoder.__init__`)."""

    ctx: DecoderContext
    z: int  # the configured lift axis
    axis_index: dict[str, int]
    motion: MotionKind
    incremental: bool
    center_absolute: bool
    unit: float
    zero_group: int
    g92: tuple[float, ...]
    offset: tuple[float, ...]
    trc: Trc
    tool_configured: bool
    open_lift: LiftStart | None

    # -- what the program decoder provides -----------------------------------------------------
    def _depth(self) -> int:
        """Sections on the call stack: 1 in the main program."""
        raise NotImplementedError

    def _warn(self, eid: ErrorId, column: int, message: str) -> None:
        raise NotImplementedError

    def _count(
        self, kind: str, column: int, message: str, eid: ErrorId = ErrorId.NOT_EMULATED
    ) -> None:
        """Something accepted but run approximated: one warning per kind, counted per block."""
        raise NotImplementedError

    def _offsets(self) -> tuple[float, ...]:
        """The zero offset in effect per axis: the selected group (G53 only with
        P-ZERO-00001) plus the G92 reference point offset."""
        group = self.zero_group
        values = self.ctx.zero_offsets.get(group) if group or self.ctx.g53_offsets else None
        if values is None:
            return self.g92
        return tuple(a + b for a, b in zip(values, self.g92, strict=True))

    def _gcodes(self, w: Words, faults: list[NcFault]) -> tuple[bool, bool]:
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
                fault = self._smoothing(kind, selects, col)
                if fault is not None:
                    faults.append(fault)
            elif code not in MODE_G:
                faults.append(
                    NcFault(ErrorId.UNSUPPORTED, col, f"G{code:02d} is not emulated by liftd")
                )
        if side is not None:
            fault = self._select_trc(side, w.gcodes[0][1])
            if fault is not None:
                faults.append(fault)
        return dwell, g92

    def _smoothing(self, kind: str, selects: bool, column: int) -> NcFault | None:
        """Smoothing is accepted and runs unsmoothed (one warning per kind). Inside a lift
        range no smoothing may be selected (vendor §2.4: "additional contour smoothing of the
        lift axis (contouring, G61/G261, G151, #SPLINE ON, #HSC ON) is not possible in the
        lifting range"); with path-based Lifting not deselected either (§2.2.1: "between
        LIFT_START and LIFT_END smoothing can not be selected or deselected")."""
        rng = self.open_lift
        if rng is not None and (selects or self.ctx.lift_method is LiftMethod.LIFTING):
            what = "selected" if selects else "deselected"
            return NcFault(
                ErrorId.SMOOTHING_IN_LIFT_RANGE,
                column,
                f"{kind.split(' (', 1)[0]}: smoothing {what} inside the lift range started in "
                f"line {rng.line} (vendor §2.4)",
            )
        if selects:
            self._count(
                kind,
                column,
                f"{kind}: smoothing is not emulated by liftd; the path "
                "runs unsmoothed (exact contour, corners as programmed)",
            )
        return None

    def _tool(self, word: tuple[float, int]) -> None:
        """D selects the tool radius for TRC (tool data wz[i].radius, P-TOOL-00004)."""
        number, col = word
        if number != int(number) or number < 0:
            raise NcFault(ErrorId.NUMBER, col, "D needs a tool number >= 0")
        radius = self.ctx.tool_radii.get(int(number))
        self.tool_configured = radius is not None or number == 0
        self.trc.set_radius(radius or 0.0)

    def _select_trc(self, side: int, column: int) -> NcFault | None:
        if side != 0 and not self.tool_configured and self.trc.side == 0:
            self._count(
                NO_RADIUS,
                column,
                "G41/G42: no tool radius configured for the selected "
                "D (liftd.toml [nc.tools] or the ISG tool list): the programmed "
                "contour runs uncompensated",
                ErrorId.TRC_NO_RADIUS,
            )
        if (
            side != 0
            and self.open_lift is not None
            and self.axis_index.get(self.open_lift.axis, self.z) in (0, 1)
        ):
            return NcFault(
                ErrorId.TRC_LIFT_AXIS,
                column,
                f"tool radius compensation in the plane of the lift axis {self.open_lift.axis} "
                f"inside the lift range started in line {self.open_lift.line} (vendor §2.4)",
            )
        self.trc.set_side(side)
        return None

    def _g92(self, w: Words) -> None:
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
