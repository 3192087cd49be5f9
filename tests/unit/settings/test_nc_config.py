"""The NC dialect's configuration (issue 19): tool radii and zero offsets from the ISG tool
and zero-offset lists and from liftd.toml's [nc] section, subroutine directories, the
expansion bound; bad values name file, line, key and value."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from liftd.settings import ConfigError, load_settings
from liftd.settings.programs import called_names, read_sources
from tests.unit.settings.test_config import (
    test_bad_values_name_file_line_key_value as check_bad_value,
)

MM = 1e-3
Machine = Callable[..., Path]


def test_shipped_tool_and_zero_offset_lists() -> None:
    ch = load_settings("config/liftd.toml").channel
    assert dict(ch.tool_radii) == pytest.approx({1: 0.1 * MM, 2: 0.075 * MM})
    zero = dict(ch.zero_offsets)
    assert zero[1] == pytest.approx((10 * MM, 10 * MM, 0.0))  # G54
    assert zero[2] == pytest.approx((1510 * MM, 10 * MM, 0.0))  # G55
    assert ch.zero_offset_default == 0 and not ch.g53_offsets
    assert ch.max_executed_blocks == 2_000_000


def test_list_flags_inaktiv_gueltig_inch_and_default_index(machine: Machine) -> None:
    cfg = machine(
        {
            "cnc/werkz_d1.lis": "wz[1].radius 1000\nwz[2].radius 5000\nwz[2].gueltig 0\n"
            "wz[3].radius 1000\nwz[3].mass_einheit 1\n",
            "cnc/nullp_d1.lis": "default_index 2\ng53_verfuegbar 1\n"
            "np_grp[0].achse[2].versch 20000\nnp_grp[2].achse[0].versch 30000\n"
            "np_grp[2].achse[1].versch 40000\nnp_grp[2].achse[1].inaktiv 1\n",
        }
    )
    ch = load_settings(str(cfg)).channel
    # tool 2 is invalid; tool 3 is in 0.0001 inch: 1000 = 0.1 inch
    assert dict(ch.tool_radii) == pytest.approx({1: 0.1 * MM, 3: 2.54 * MM})
    assert dict(ch.zero_offsets) == {
        0: pytest.approx((0.0, 0.0, 2 * MM)),
        2: pytest.approx((3 * MM, 0.0, 0.0)),
    }
    assert ch.zero_offset_default == 2 and ch.g53_offsets


def test_toml_values_override_the_lists(machine: Machine) -> None:
    cfg = machine()
    cfg.write_text(
        cfg.read_text() + "\n[nc]\nsubroutine_dirs = ['subs', '/opt/cam']\n"
        "max_executed_blocks = 5000\n[nc.tools]\nD1 = 0.25\nD7 = 1.5\n"
        "[nc.zero_offsets]\nG54 = { X = 100.0 }\nG59 = { Y = 5.5, Z = -1 }\n"
    )
    s = load_settings(str(cfg))
    ch = s.channel
    assert dict(ch.tool_radii) == pytest.approx({1: 0.25 * MM, 2: 0.075 * MM, 7: 1.5 * MM})
    zero = dict(ch.zero_offsets)
    assert zero[1] == pytest.approx((100 * MM, 10 * MM, 0.0))  # Y from the list stays
    assert zero[6] == pytest.approx((0.0, 5.5 * MM, -1 * MM))
    assert ch.max_executed_blocks == 5000
    assert s.subroutine_dirs == (cfg.parent / "subs", Path("/opt/cam"))


@pytest.mark.parametrize(
    ("text", "line", "key", "value", "fragment"),
    [
        ("[nc.tools]\nD1 = 0.1\nT2 = 0.1\n", 3, "nc.tools.T2", "T2", "D"),
        ("[nc.tools]\nD1 = -0.1\n", 2, "nc.tools.D1", "-0.1", "greater than or equal to 0"),
        ("[nc]\ntools = { D1 = 'x' }\n", 2, "nc.tools.D1", "x", "valid number"),
        ("[nc.zero_offsets]\nG60 = { X = 1 }\n", 2, "nc.zero_offsets.G60", "G60", "G59"),
        (
            "[nc.zero_offsets]\nG54 = { X = 2e6 }\n",
            2,
            "nc.zero_offsets.G54.X",
            "2000000.0",
            "less than or equal to 1000000",
        ),
        ("[nc]\nmax_executed_blocks = 10\n", 2, "nc.max_executed_blocks", "10", "1000"),
        ("[nc]\nsubroutine_dir = ['x']\n", 2, "nc.subroutine_dir", None, "unknown key"),
    ],
)
def test_bad_nc_values_name_file_line_key_value(
    text: str, line: int, key: str, value: str | None, fragment: str
) -> None:
    check_bad_value(text, line, key, value, fragment)


def test_zero_offset_of_an_unknown_axis_is_a_configuration_error(machine: Machine) -> None:
    cfg = machine()
    cfg.write_text(cfg.read_text() + "\n[nc.zero_offsets]\nG54 = { X = 1.0, A = 2.0 }\n")
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    (p,) = [p for p in exc.value.problems if p.severity.value == "error"]
    assert (p.key, p.value) == ("nc.zero_offsets.G54.A", "2.0")
    assert p.line == len(cfg.read_text().splitlines())
    assert "not an axis of the channel (axes: X, Y, Z)" in p.message


def test_bad_list_entries_name_their_line(machine: Machine) -> None:
    cfg = machine({"cnc/werkz_d1.lis": "wz[1].radius 1000\nwz[2].radius big\n"})
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    assert any(
        p.file.endswith("werkz_d1.lis") and p.line == 2 and p.key == "wz[2].radius"
        for p in exc.value.problems
    )


def test_called_names_and_the_search_path(tmp_path: Path) -> None:
    text = "L a.nc\nLL local\nN10 L b.nc ; L c.nc\nL SEQUENCE [NAME=d.nc N1 N2]\nX1 L4711\n"
    assert called_names(text) == ["a.nc", "b.nc", "c.nc", "4711", "d.nc"]
    (tmp_path / "prog").mkdir()
    (tmp_path / "lib").mkdir()
    (tmp_path / "prog" / "a.nc").write_text("L B.NC\nM17\n")
    (tmp_path / "lib" / "b.nc").write_text("M17\n")
    program = tmp_path / "prog" / "main.nc"
    sources = read_sources(program, "L a.nc\nL zz.nc\n", [tmp_path / "lib"])
    found = {f.name: (f.path, f.text is not None, f.error) for f in sources.files}
    assert sources.program == str(program)
    assert found["a.nc"] == (str(tmp_path / "prog" / "a.nc"), True, None)
    assert found["B.NC"] == (str(tmp_path / "lib" / "b.nc"), True, None)  # case ignored
    assert found["zz.nc"][1] is False and "not found" in str(found["zz.nc"][2])
