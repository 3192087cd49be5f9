"""`[ui]` beyond the model: the control token (inline, or read from the file `token_file`
names, relative to liftd.toml) and the rule that control needs one. Problems name file, line,
key and value; the token itself is never shown."""

from __future__ import annotations

import re
from pathlib import Path

from liftd.settings.config_file import toml_line
from liftd.settings.isg_list import Problem, Severity
from liftd.settings.model import UiSection

HIDDEN = "(hidden)"
TOKEN = re.compile(r"^[!-~]{16,256}$")  # printable ASCII without blanks, 16..256 characters


def ui_token(ui: UiSection, base: Path, file: str, text: str,
             problems: list[Problem]) -> str | None:  # fmt: skip
    """The control token `[ui]` gives, or None; problems are appended to `problems`."""

    def error(key: str, value: str | None, message: str) -> None:
        line = toml_line(text, ("ui", key))
        problems.append(Problem(Severity.ERROR, file, line, f"ui.{key}", value, message))

    if ui.token is not None and ui.token_file is not None:
        error("token_file", ui.token_file, "give the token or a token_file, not both")
        return None
    token = ui.token
    if ui.token_file is not None:
        path = base / ui.token_file
        try:
            token = path.read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc)
            error("token_file", ui.token_file, f"cannot read the token file {path}: {reason}")
            return None
        if not TOKEN.match(token):
            error("token_file", ui.token_file, f"{path} must hold one token of 16..256 "
                  "printable ASCII characters without blanks")  # fmt: skip
            return None
    if ui.control and token is None:
        error("control", "true", "control from the page needs [ui] token or token_file")
    return token
