"""`[ui] token_file` readable beyond its owner: `ui.token_file_permissions` is logged (review
#9a); a file only its owner reads is not."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from liftd.service.daemon import Daemon
from liftd.settings import load_settings
from tests.support.daemon import write_config


class Log:
    def __init__(self) -> None:
        self.lines: list[tuple[str, dict[str, Any]]] = []

    def warning(self, event: str, **kw: Any) -> None:
        self.lines.append((event, kw))


def test_a_token_file_readable_by_others_is_warned_about(tmp_path: Path) -> None:
    token = tmp_path / "ui.token"
    token.write_text("a-token-of-twenty-chars\n")
    cfg = write_config(tmp_path, ui={"enabled": True, "control": True, "token_file": "ui.token"})
    d = Daemon(load_settings(str(cfg)), None, None, None)
    try:
        assert d.ui is not None
        log = Log()
        d.ui.log = log
        token.chmod(0o600)
        d.ui.check_token_file()
        assert log.lines == []
        token.chmod(0o644)
        d.ui.check_token_file()
        ((event, kw),) = log.lines
        assert event == "ui.token_file_permissions" and kw["mode"] == "644"
        assert kw["file"] == str(token)
    finally:
        d.shared.close()
