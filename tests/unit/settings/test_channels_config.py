"""The channels of the start-up list and liftd.toml's [[channel]] tables (issue 18 items 1
and 4): the shipped two-head configuration, and each bad input as an error naming file,
line and what is wrong."""

from __future__ import annotations

from pathlib import Path

import pytest

from liftd.settings import ConfigError, load_settings
from liftd.settings.config_file import toml_line
from tests.support.paths import REPO
from tests.support.settings import copy_two_head_machine, edit

CONFIG = REPO / "config"


def test_the_shipped_two_head_configuration() -> None:
    s = load_settings(str(CONFIG / "liftd-2ch.toml"))
    assert [c.params.channel_id for c in s.machine] == [1, 2]
    one, two = (c.params for c in s.machine)
    assert s.channel == one and s.primary_index == 0
    assert one.axis_names == ("X", "Y", "Z") and two.axis_names == ("U", "V", "W")
    assert [ax.log_axis_nr for ax in two.axes] == [4, 5, 6]
    assert (one.lift_method.value, two.lift_method.value) == ("advanced", "lifting")
    assert (
        two.lift_axis == "W"
        and s.machine[1].program == CONFIG / "programs" / "two-head" / "head2.nc"
    )
    assert s.machine[1].repeat and s.machine[1].autostart
    assert str(CONFIG / "cnc-2ch" / "sda_mds2.lis") in s.files


def test_a_single_channel_configuration_is_one_channel() -> None:
    s = load_settings(str(CONFIG / "liftd.toml"))
    assert len(s.machine) == 1 and s.machine[0].params == s.channel


@pytest.fixture
def machine(tmp_path: Path) -> Path:
    return copy_two_head_machine(tmp_path)


def errors(root: Path) -> list[str]:
    with pytest.raises(ConfigError) as err:
        load_settings(str(root / "liftd.toml"))
    return [str(p) for p in err.value.problems if p.severity.value == "error"]


def line_of(path: Path, text: str) -> int:
    return next(n for n, line in enumerate(path.read_text().splitlines(), 1) if text in line)


def test_a_channel_list_missing_for_kanal_anzahl(machine: Path) -> None:
    startup = machine / "cnc-2ch" / "hochlauf.lis"
    edit(startup, "kanal_anzahl                 2", "kanal_anzahl                 3")
    (found,) = errors(machine)
    assert f"{startup}:{line_of(startup, 'kanal_anzahl')}: kanal_anzahl" in found
    assert "no channel list sda_mds[2] for channel 3" in found


def test_a_channel_list_beyond_kanal_anzahl(machine: Path) -> None:
    startup = machine / "cnc-2ch" / "hochlauf.lis"
    edit(startup, "kanal_anzahl                 2", "kanal_anzahl                 1")
    found = errors(machine)
    assert any(
        f"{startup}:{line_of(startup, 'sda_mds[1]')}: sda_mds[1]" in e
        and "channel 2, but kanal_anzahl is 1" in e
        for e in found
    ), found


def test_a_channel_list_that_cannot_be_read(machine: Path) -> None:
    (machine / "cnc-2ch" / "sda_mds2.lis").unlink()
    found = errors(machine)
    assert any("sda_mds2.lis" in e and "cannot read list file" in e for e in found), found


def test_a_program_for_a_channel_that_does_not_exist(machine: Path) -> None:
    cfg = machine / "liftd.toml"
    edit(cfg, "id = 2 ", "id = 3 ")
    (found,) = errors(machine)
    assert found.startswith(f"{cfg}:{line_of(cfg, 'id = 3')}: channel.0.id = '3' error:")
    assert "channel 3, which the start-up list" in found and "(channels 1, 2)" in found


def test_a_second_table_for_the_cnc_channel_or_one_channel(machine: Path) -> None:
    cfg = machine / "liftd.toml"
    edit(cfg, "id = 2 ", "id = 1 ")
    (found,) = errors(machine)
    assert f"{cfg}:{line_of(cfg, 'id = 1')}: channel.0.id" in found and "[cnc] channel" in found
    cfg.write_text(cfg.read_text().replace("id = 1 ", "id = 2 ") + "\n[[channel]]\nid = 2\n")
    (found,) = errors(machine)
    assert f"{cfg}:{len(cfg.read_text().splitlines())}: channel.1.id" in found
    assert "two [[channel]] tables" in found


def test_a_lift_axis_that_is_not_in_the_channel(machine: Path) -> None:
    cfg = machine / "liftd.toml"
    edit(cfg, 'lift_axis = "W"', 'lift_axis = "Z"')
    (found,) = errors(machine)
    line = max(n for n, text in enumerate(cfg.read_text().splitlines(), 1) if "lift_axis" in text)
    assert found.startswith(f"{cfg}:{line}: channel.0.lift_axis = 'Z' error:"), found
    assert "not an axis of channel 2 (axes: U, V, W)" in found


def test_two_channels_sharing_an_axis(machine: Path) -> None:
    chan = machine / "cnc-2ch" / "sda_mds2.lis"
    edit(chan, "gruppe[0].achse[2].log_achs_nr     6", "gruppe[0].achse[2].log_achs_nr     3")
    (found,) = errors(machine)
    line = line_of(chan, "achse[2].log_achs_nr")
    assert found.startswith(f"{chan}:{line}: log_achs_nr = '3' error:"), found
    assert "axis W of channel 2 is logical axis 3, which is already in channel 1" in found


def test_the_cnc_channel_must_be_one_of_the_list(machine: Path) -> None:
    cfg = machine / "liftd.toml"
    edit(cfg, "channel = 1", "channel = 4")
    found = errors(machine)
    assert any(f"{cfg}:{line_of(cfg, 'channel = 4')}: cnc.channel = '4'" in e for e in found)


def test_toml_line_finds_keys_of_the_nth_array_table() -> None:
    text = "[cnc]\nchannel = 1\n[[channel]]\nid = 2\n[[channel]]\nid = 3\nlift_axis = 'Q'\n"
    assert toml_line(text, ("channel", 0, "id")) == 4
    assert toml_line(text, ("channel", 1, "id")) == 6
    assert toml_line(text, ("channel", 1, "lift_axis")) == 7
    assert toml_line(text, ("cnc", "channel")) == 2
