"""liftd.toml: contract keys, validation messages with file/line/key/value, search order."""

from __future__ import annotations

from pathlib import Path

import pytest

from liftd.settings import ConfigError, load_settings
from liftd.settings.config_file import default_config_path, find_config, parse_config_text
from liftd.settings.model import LiftdConfig
from tests.support.paths import REPO
from tests.support.settings import copy_two_head_machine, edit

CONTRACT = """
[cnc]
startup_list = "cnc/hochlauf.lis"
channel = 1
lift_axis = "Z"
cycle_time_us = 1000
[program]
file = "programs/demo.nc"
autostart = true
repeat = false
[ads]
host = "127.0.0.1"
port = 48898
net_id = "127.0.0.1.1.1"
"""


def test_contract_keys_are_accepted_and_everything_else_defaults() -> None:
    cfg = parse_config_text(CONTRACT, "x.toml")
    assert cfg.cnc.cycle_time_us == 1000 and cfg.ads.net_id == "127.0.0.1.1.1"
    assert parse_config_text("", "empty.toml") == LiftdConfig()


@pytest.mark.parametrize(
    ("text", "line", "key", "value", "fragment"),
    [
        (
            "[cnc]\ncycle_time_us = 100\n",
            2,
            "cnc.cycle_time_us",
            "100",
            "greater than or equal to 250",
        ),
        ('[cnc]\nchannel = 1\nlift_axs = "Z"\n', 3, "cnc.lift_axs", "Z", "unknown key"),
        ('[ads]\nnet_id = "1.2.3"\n', 2, "ads.net_id", "1.2.3", "six numbers"),
        ('[ads]\nport = "x"\n', 2, "ads.port", "x", "must be a number, not a string"),
        ("[adss]\nport = 1\n", 1, "adss", None, "unknown key"),
        ('[ads]\nallow_ips = ["10.0.0.0/33"]\n', 2, "ads.allow_ips", None, "10.0.0.0/33"),
        ('[ads]\nudp_discovery = "yes"\n', 2, "ads.udp_discovery", "yes", "valid boolean"),
        ("[ads]\nfirst_frame_timeout_s = 0\n", 2, "ads.first_frame_timeout_s", "0", "greater than"),
        ("[log]\nqueue_lines = 5\n", 2, "log.queue_lines", "5", "greater than or equal"),
        ('[rt]\nidle = "nap"\n', 2, "rt.idle", "nap", "'sleep' or 'spin'"),
    ],
)
def test_bad_values_name_file_line_key_value(
    text: str, line: int, key: str, value: str | None, fragment: str
) -> None:
    with pytest.raises(ConfigError) as exc:
        parse_config_text(text, "bad.toml")
    (p,) = exc.value.problems
    assert (p.file, p.line, p.key) == ("bad.toml", line, key)
    if value is not None:
        assert p.value == value
    assert fragment in p.message


def test_udp_discovery_is_off_by_default_and_on_only_in_the_loopback_config() -> None:
    assert LiftdConfig().ads.udp_discovery is False
    shipped = parse_config_text((REPO / "config" / "liftd.toml").read_text(), "liftd.toml")
    assert shipped.ads.udp_discovery is True and shipped.ads.host == "127.0.0.1"
    docker = parse_config_text((REPO / "docker" / "liftd.toml").read_text(), "liftd.toml")
    assert docker.ads.udp_discovery is False  # listens on every address of the container


def test_toml_syntax_error_has_a_line() -> None:
    with pytest.raises(ConfigError) as exc:
        parse_config_text("[cnc]\nchannel = = 2\n", "syn.toml")
    assert exc.value.problems[0].line == 2
    assert str(exc.value).startswith("syn.toml:2: error: TOML syntax")


def test_missing_config_file() -> None:
    with pytest.raises(ConfigError) as exc:
        load_settings("/nonexistent/liftd.toml")
    assert "cannot read" in str(exc.value)


def test_search_order(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("LIFTD_CONFIG", raising=False)
    assert find_config(None) == default_config_path()
    (tmp_path / "config").mkdir()
    (tmp_path / "config" / "liftd.toml").write_text("")
    assert find_config(None) == Path("config/liftd.toml")
    monkeypatch.setenv("LIFTD_CONFIG", "/etc/liftd/liftd.toml")
    assert find_config(None) == Path("/etc/liftd/liftd.toml")
    assert find_config("mine.toml") == Path("mine.toml")


def test_packaged_default_config_loads_from_anywhere(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("LIFTD_CONFIG", raising=False)
    s = load_settings()
    assert s.path == default_config_path()
    assert s.program is not None and s.program.name == "demo.nc" and s.program.is_file()


def test_repo_config_is_the_default_in_a_source_checkout() -> None:
    assert default_config_path() in (
        REPO / "config" / "liftd.toml",
        Path(__file__).resolve().parents[3] / "liftd" / "_config" / "liftd.toml",
    )


@pytest.mark.parametrize(
    ("keys", "key", "value", "fragment"),
    [
        ("max_frame_bytes = 1048576\nconnection_budget_bytes = 2000000", "connection_budget_bytes",
         "2000000", "below 2 × max_frame_bytes (2097152)"),
        ("connection_budget_bytes = 8388608\nbudget_bytes = 4194304", "budget_bytes", "4194304",
         "below connection_budget_bytes (8388608)"),
    ],
)  # fmt: skip
def test_memory_budgets_below_what_they_must_hold(
    tmp_path: Path, keys: str, key: str, value: str, fragment: str
) -> None:
    """A connection's budget holds a frame in and a frame out; the server's a connection's."""
    machine = copy_two_head_machine(tmp_path)
    edit(machine / "liftd.toml", "[ads]\n", f"[ads]\n{keys}\n")
    with pytest.raises(ConfigError) as exc:
        load_settings(str(machine / "liftd.toml"))
    (p,) = exc.value.problems
    lines = (machine / "liftd.toml").read_text().splitlines()
    line = next(n for n, text in enumerate(lines, 1) if text.startswith(f"{key} ="))
    assert (p.file, p.line, p.key, p.value) == (
        str(machine / "liftd.toml"),
        line,
        f"ads.{key}",
        value,
    )
    assert fragment in p.message
