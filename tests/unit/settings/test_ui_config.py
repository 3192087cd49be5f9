"""[ui]: off unless asked (on in the shipped liftd.toml, on loopback), and every bad value a
problem naming file, line, key and value; the token itself is never printed."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from liftd.settings import ConfigError, load_settings
from liftd.settings.config_file import parse_config_text
from liftd.settings.model import LiftdConfig
from tests.support.paths import REPO

TOKEN = "s3cret-token-0123456789"


def test_off_by_default_and_on_loopback_in_the_shipped_config() -> None:
    assert LiftdConfig().ui.enabled is False
    shipped = load_settings(str(REPO / "config" / "liftd.toml")).config.ui
    assert (shipped.enabled, shipped.host, shipped.port, shipped.control) == (
        True, "127.0.0.1", 8551, False)  # fmt: skip


@pytest.mark.parametrize(
    ("text", "line", "key", "value", "fragment"),
    [
        ("[ui]\nport = 70000\n", 2, "ui.port", "70000", "less than or equal"),
        ('[ui]\nenabled = "yes"\n', 2, "ui.enabled", "yes", "valid boolean"),
        ("[ui]\nrate_hz = 500\n", 2, "ui.rate_hz", "500", "less than or equal to 50"),
        ('[ui]\ntoken = "short"\n', 2, "ui.token", "(hidden)", "at least 16"),
        ('[ui]\ntoken = "has a blank in it, 16+"\n', 2, "ui.token", "(hidden)", "pattern"),
        ("[ui]\nmax_connections = 0\n", 2, "ui.max_connections", "0", "greater than"),
        ("[ui]\nwho = 1\n", 2, "ui.who", "1", "unknown key"),
    ],
)
def test_bad_values_name_file_line_key_value(
    text: str, line: int, key: str, value: str, fragment: str
) -> None:
    with pytest.raises(ConfigError) as exc:
        parse_config_text(text, "bad.toml")
    (p,) = exc.value.problems
    assert (p.file, p.line, p.key, p.value) == ("bad.toml", line, key, value)
    assert fragment in p.message
    assert "short" not in str(p) and "blank" not in str(p)


def _config(tmp: Path, ui: str) -> Path:
    shutil.copytree(REPO / "config" / "cnc", tmp / "cnc")
    path = tmp / "liftd.toml"
    path.write_text(f"[program]\nautostart = false\n\n[ui]\n{ui}")
    return path


def test_control_needs_a_token(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as exc:
        load_settings(str(_config(tmp_path, "enabled = true\ncontrol = true\n")))
    (p,) = exc.value.problems
    assert (p.line, p.key, p.value) == (6, "ui.control", "true")
    assert "token" in p.message


def test_token_from_a_file_relative_to_the_config(tmp_path: Path) -> None:
    (tmp_path / "ui.token").write_text(TOKEN + "\n")
    s = load_settings(str(_config(tmp_path, 'control = true\ntoken_file = "ui.token"\n')))
    assert s.ui_token == TOKEN
    assert TOKEN not in repr(s)


@pytest.mark.parametrize(
    ("ui", "content", "fragment"),
    [
        ('token_file = "none.token"\n', None, "cannot read the token file"),
        ('token_file = "ui.token"\n', "two words", "one token of 16..256"),
        (f'token = "{TOKEN}"\ntoken_file = "ui.token"\n', TOKEN, "not both"),
    ],
)
def test_bad_token_files(tmp_path: Path, ui: str, content: str | None, fragment: str) -> None:
    if content is not None:
        (tmp_path / "ui.token").write_text(content)
    with pytest.raises(ConfigError) as exc:
        load_settings(str(_config(tmp_path, ui)))
    (p,) = exc.value.problems
    assert p.key == "ui.token_file" and p.line is not None and fragment in p.message
    assert TOKEN not in str(p)


def test_liftd_run_exits_2_naming_the_line(tmp_path: Path) -> None:
    path = _config(tmp_path, "enabled = true\nport = -1\n")
    r = subprocess.run([sys.executable, "-m", "liftd", "run", "-c", str(path)],
                       capture_output=True, text=True, timeout=60, check=False)  # fmt: skip
    assert r.returncode == 2
    assert f"{path}:6" in r.stderr and "ui.port" in r.stderr and "-1" in r.stderr
