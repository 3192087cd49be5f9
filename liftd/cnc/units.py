"""The only place with unit factors: ISG list units and NC program units to SI and back.

Inside liftd everything is SI (m, s, m/s, m/s², m/s³, fractions). ISG lists use 0.1 µm for
positions, µm/s for axis velocities, mm/s² for accelerations, µs for ramp times and 0.1 % for
percentages (docs/reference/isg-cnc.md §3); NC programs use mm and mm/min (G94).
"""

from __future__ import annotations

M_PER_MM = 1e-3
M_PER_ISG_POS = 1e-7  # 0.1 µm (P-AXIS-00177/00178, P-CHAN-00244, P-CHAN-00171)
M_S_PER_ISG_VEL = 1e-6  # µm/s (P-AXIS-00212 vb_max)
M_S2_PER_ISG_ACC = 1e-3  # mm/s² (P-AXIS-00008 a_max)
S_PER_ISG_TIME = 1e-6  # µs (P-AXIS-00201 tr_min)
FRACTION_PER_ISG_PERMILLE = 1e-3  # 0.1 % (P-AXIS-00441/00442, overrides)
M_S_PER_MM_MIN = 1e-3 / 60.0  # F word under G94
M_PER_INCH = 25.4e-3  # G70: positions in inch, F in inch/min
M_PER_ISG_INCH = 2.54e-6  # 0.0001 inch (tool list wz[i].radius with mass_einheit 1)


def isg_pos_to_m(raw: int) -> float:
    return raw * M_PER_ISG_POS


def m_to_isg_pos(value_m: float) -> int:
    return round(value_m / M_PER_ISG_POS)


def isg_vel_to_m_s(raw: int) -> float:
    return raw * M_S_PER_ISG_VEL


def m_s_to_isg_vel(value_m_s: float) -> float:
    return value_m_s / M_S_PER_ISG_VEL


def isg_acc_to_m_s2(raw: int) -> float:
    return raw * M_S2_PER_ISG_ACC


def isg_time_to_s(raw: int) -> float:
    return raw * S_PER_ISG_TIME


def isg_permille_to_fraction(raw: int) -> float:
    return raw * FRACTION_PER_ISG_PERMILLE


def fraction_to_isg_permille(value: float) -> int:
    return round(value / FRACTION_PER_ISG_PERMILLE)


def mm_to_m(value_mm: float) -> float:
    return value_mm * M_PER_MM


def m_to_mm(value_m: float) -> float:
    return value_m / M_PER_MM


def mm_min_to_m_s(value_mm_min: float) -> float:
    return value_mm_min * M_S_PER_MM_MIN


def jerk_from_ramp(a_max_m_s2: float, tr_min_s: float) -> float:
    """Axis jerk limit = a_max / tr_min (P-AXIS-00201); tr_min = 0 means no jerk limit."""
    return a_max_m_s2 / tr_min_s if tr_min_s > 0.0 else float("inf")


def inch_to_m(value_inch: float) -> float:
    return value_inch * M_PER_INCH


def isg_inch_to_m(raw: int) -> float:
    """0.0001 inch (ISG tool data in inch, P-TOOL-00004) to m."""
    return raw * M_PER_ISG_INCH


def program_length_factor(inch: bool) -> float:
    """m per unit of a length word in the NC program: mm under G71, inch under G70."""
    return M_PER_INCH if inch else M_PER_MM
