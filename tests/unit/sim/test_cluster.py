"""The cluster study's client-side parts that need no cluster: which subroutine files are
scattered once (a library's, called by a second program) and which travel with their task."""

from __future__ import annotations

import pytest

pytest.importorskip("distributed")

from liftd.cnc.params import NcFile
from liftd.sim import cluster


class Client:
    """Records scatters; a scattered text comes back as ("future", text)."""

    def __init__(self) -> None:
        self.scattered: list[str] = []

    def scatter(self, data: str, broadcast: bool, hash: bool) -> tuple[str, str]:
        assert broadcast and not hash
        self.scattered.append(data)
        return ("future", data)


def test_a_file_is_scattered_once_from_its_second_caller_on() -> None:
    client = Client()
    shared = cluster._SharedFiles(client)  # type: ignore[arg-type]
    lib = NcFile("plate.nc", "/lib/plate.nc", "N1 G01 X1\nM17\n")
    own = NcFile("job1.nc", "/jobs/job1.nc", "N1 G01 X2\nM17\n")
    assert shared.text(lib) == lib.text and shared.text(own) == own.text  # first caller: inline
    assert shared.text(lib) == ("future", lib.text)  # second: scattered
    assert shared.text(lib) == ("future", lib.text)  # third: the same future
    assert client.scattered == [lib.text]
    same_name = NcFile("plate.nc", "/other/plate.nc", lib.text)  # another file, same text
    assert shared.text(same_name) == lib.text
    assert shared.text(NcFile("gone.nc", "gone.nc", error="not found")) is None


def test_the_scattered_files_are_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cluster, "MAX_SHARED_FILES", 2)
    client = Client()
    shared = cluster._SharedFiles(client)  # type: ignore[arg-type]
    files = [NcFile(f"f{k}.nc", f"/lib/f{k}.nc", f"N{k} M17\n") for k in range(4)]
    for _ in range(2):
        results = [shared.text(f) for f in files]
    assert results[:2] == [("future", f.text) for f in files[:2]]
    assert results[2:] == [f.text for f in files[2:]]  # inline once the bound is reached
    assert len(client.scattered) == 2
