"""Compile the GEO cycle's modules (`liftd.cnc.COMPILED`) and the per-cycle part of `simulate`
(`liftd.sim.COMPILED`) and the GEO process's loop (`liftd.runtime.COMPILED`) to C extensions
with mypyc, in place.

`make` runs it before `run` and `test`; the extension (`*.so`) sits next to its source and
Python imports it first. Same source, same results bit for bit (tests/unit/cnc/
test_compiled.py), about 3× less CPU per GEO cycle (docs/figures.md). Needs a C compiler and
the Python headers; without them it says so and exits 0: liftd then runs the core as Python
(slower, same results), and `liftd check` says which one runs.

Run: .venv/bin/python tools/compile_core.py [--clean]
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from liftd import cnc, runtime, sim  # noqa: E402
from liftd.runtime.core import SOURCES, source_hash  # noqa: E402

COMPILED = cnc.COMPILED + sim.COMPILED + runtime.COMPILED

BUILD = ROOT / "build" / "mypyc"


def sources() -> list[str]:
    return [str(Path(*m.split(".")).with_suffix(".py")) for m in COMPILED]


def clean() -> None:
    for m in COMPILED:
        for so in (ROOT / Path(*m.split(".")).parent).glob(m.rsplit(".", 1)[1] + ".*.so"):
            so.unlink()
    for so in [*ROOT.glob("*__mypyc*.so"), *(ROOT / "liftd").glob("*__mypyc*.so")]:
        so.unlink()
    (ROOT / "liftd" / SOURCES).unlink(missing_ok=True)
    shutil.rmtree(BUILD, ignore_errors=True)


@contextlib.contextmanager
def _output_to(log: IO[str]) -> Iterator[None]:
    """stdout and stderr of this process and of the compiler it runs, into `log`."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    os.dup2(log.fileno(), 1)
    os.dup2(log.fileno(), 2)
    try:
        yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])


def _build() -> None:
    from mypyc.build import mypycify  # noqa: PLC0415
    from setuptools import Distribution  # noqa: PLC0415

    # group_name: the shared runtime module is liftd/_core__mypyc.*.so, inside the package
    ext = mypycify(sources(), group_name="liftd._core", target_dir=str(BUILD / "c"))
    dist = Distribution({"name": "liftd-core", "ext_modules": ext})
    cmd = dist.get_command_obj("build_ext")
    cmd.inplace = True  # type: ignore[attr-defined]
    cmd.build_temp = str(BUILD / "temp")  # type: ignore[attr-defined]
    dist.run_command("build_ext")


def main() -> int:
    clean()
    if "--clean" in sys.argv:
        return 0
    try:
        import mypyc.build  # noqa: F401, PLC0415
        import setuptools  # noqa: F401, PLC0415
    except ImportError as exc:
        print(f"compile_core: {exc}; the GEO core runs as Python", file=sys.stderr)
        return 0
    os.chdir(ROOT)  # mypycify takes paths relative to the tree and names modules by them
    print(f"compile_core: compiling {len(COMPILED)} modules with mypyc (about a minute)…",
          file=sys.stderr, flush=True)  # fmt: skip
    with tempfile.TemporaryFile("w+") as log:
        try:
            with _output_to(log):  # the compiler's lines, shown only when it fails
                _build()
        except (SystemExit, Exception) as exc:  # a missing compiler or headers: not fatal
            clean()
            log.seek(0)
            tail = "".join(log.readlines()[-15:])
            why = f"not compiled ({exc}); the GEO core runs as Python (same results, slower)"
            print(f"{tail}compile_core: {why}; with a compiler: make core", file=sys.stderr)
            return 0
    record = {m: source_hash(ROOT / src) for m, src in zip(COMPILED, sources(), strict=True)}
    (ROOT / "liftd" / SOURCES).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    print(f"compile_core: {len(COMPILED)} modules compiled", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
