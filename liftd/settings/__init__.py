"""Configuration: liftd.toml (pydantic, frozen) and the ISG lists it points at, validated once
and mapped to the core's parameters (`liftd.cnc` params); every problem names file, line, key
and value.

May import the core `liftd.cnc` (parameter types); nothing else of liftd.
"""

from __future__ import annotations

from liftd.settings.config_file import ConfigError
from liftd.settings.isg_list import Problem, Severity
from liftd.settings.load import Settings, load_settings

__all__ = ["ConfigError", "Problem", "Settings", "Severity", "load_settings"]
