"""Reading one ISG list file into typed values while collecting its problems (file, line,
key, value, message), and the small accessors the list readers share."""

from __future__ import annotations

from pathlib import Path

from liftd.settings.isg_list import Problem, Severity, read_list
from liftd.settings.isg_schema import KeySpec, TypedList, Value, type_list


class ListReader:
    """Collects problems while reading and typing list files."""

    def __init__(self) -> None:
        self.problems: list[Problem] = []
        self.files: list[str] = []

    def error(self, value: Value | None, message: str, file: str | None = None) -> None:
        if value is None:
            self.problems.append(Problem(Severity.ERROR, file or "?", None, None, None, message))
            return
        e = value.entry
        self.problems.append(Problem(Severity.ERROR, e.file, e.line, e.key, e.value, message))

    def read(self, path: Path, specs: tuple[KeySpec, ...], ref: Value | None) -> TypedList | None:
        try:
            parsed = read_list(path)
        except OSError as exc:
            reason = exc.strerror or type(exc).__name__
            self.error(ref, f"cannot read list file {str(path)!r}: {reason}", str(path))
            return None
        self.files.append(str(path))
        values, problems = type_list(parsed, specs)
        self.problems.extend(problems)
        return values


def as_int(value: Value) -> int:
    assert isinstance(value.value, int)
    return value.value


def int_of(values: TypedList, key: str, default: int) -> int:
    v = values.get(key)
    return v.value if v is not None and isinstance(v.value, int) else default


def real_of(values: TypedList, key: str, default: float) -> float:
    v = values.get(key)
    if v is None or isinstance(v.value, (bool, str, frozenset)):
        return default
    return float(v.value)


def flags_of(values: TypedList, key: str) -> Value | None:
    v = values.get(key)
    return v if v is not None and isinstance(v.value, frozenset) else None
