"""Configuration: liftd.toml (pydantic) and the ISG lists, mapped to core parameters."""

from __future__ import annotations

from liftd.settings.isg_list import Problem, Severity
from liftd.settings.load import ConfigError, Settings, load_settings

__all__ = ["ConfigError", "Problem", "Settings", "Severity", "load_settings"]
