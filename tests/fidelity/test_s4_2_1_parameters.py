"""Vendor §4.2.1 "Activate lift function": the interpolator's look-ahead sizes."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from liftd.settings import ConfigError, load_settings

Machine = Callable[..., Path]
IPO = "configuration.channel[0].interpolator.function"
LAH = "configuration.interpolator.number_blocks_lah"


def _custom(machine: Machine, blocks: str) -> Path:
    return machine(
        {
            "cnc/hochlauf.lis": {IPO: "FCT_LOOK_AHEAD_CUSTOM | FCT_LIFT_UP_TIME"},
            "cnc/sda_mds1.lis": {LAH: blocks},
        }
    )


@pytest.mark.parametrize(("blocks", "expect"), [("0", 1), ("1", 1), ("10", 10), ("200", 200)])
def test_s4_2_1_look_ahead_custom_takes_0_to_200_blocks(
    machine: Machine, blocks: str, expect: int
) -> None:
    """§4.2.1: "FCT_LOOK_AHEAD_CUSTOM: any number of look-ahead blocks in the interval
    [0; 200], specified by P-CHAN-00653". 0 blocks means no look-ahead beyond the block
    being run: the path is planned one block at a time (it can stop at every block end),
    which the interpolator gets as a window of 1 block."""
    cfg = _custom(machine, blocks)
    assert load_settings(str(cfg)).channel.look_ahead_blocks == expect


def test_s4_2_1_look_ahead_custom_above_200_is_a_configuration_error(machine: Machine) -> None:
    cfg = _custom(machine, "201")
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    (problem,) = exc.value.problems
    assert problem.key == LAH and problem.value == "201"
    assert "200" in problem.message
