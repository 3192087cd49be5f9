"""Compile the GEO cycle's modules (`liftd.cnc.COMPILED`) and the per-cycle part of `simulate`
(`liftd.sim.COMPILED`) to C extensions with mypyc, in place.

`make` runs it before `run` and `test`; the extension (`*.so`) sits next to its source and
Python imports it first. Same source, same results bit for bit (tests/unit/cnc/
test_compiled.py), about 3× less CPU per GEO cycle (README "Figures"). Needs a C compiler and
the Python headers; without them it says so and exits 0: liftd then runs the core as Python
(slower, same results), and `liftd check` says which one runs.

Run: .venv/bin/python tools/compile_core.py [--clean]
"""

from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from liftd import cnc, sim  # noqa: E402
from liftd.runtime.core import SOURCES, source_hash  # noqa: E402

COMPILED = cnc.COMPILED + sim.COMPILED

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


def main() -> int:
    clean()
    if "--clean" in sys.argv:
        return 0
    try:
        from mypyc.build import mypycify  # noqa: PLC0415
        from setuptools import Distribution  # noqa: PLC0415
    except ImportError as exc:
        print(f"compile_core: {exc}; the GEO core runs as Python", file=sys.stderr)
        return 0
    os.chdir(ROOT)  # mypycify takes paths relative to the tree and names modules by them
    try:
        # group_name: the shared runtime module is liftd/_core__mypyc.*.so, inside the package
        ext = mypycify(sources(), group_name="liftd._core", target_dir=str(BUILD / "c"))
        dist = Distribution({"name": "liftd-core", "ext_modules": ext})
        cmd = dist.get_command_obj("build_ext")
        cmd.inplace = True  # type: ignore[attr-defined]
        cmd.build_temp = str(BUILD / "temp")  # type: ignore[attr-defined]
        dist.run_command("build_ext")
    except (SystemExit, Exception) as exc:  # a missing compiler or headers: not fatal
        clean()
        print(f"compile_core: not compiled ({exc}); the GEO core runs as Python", file=sys.stderr)
        return 0
    record = {m: source_hash(ROOT / Path(*m.split(".")).with_suffix(".py")) for m in COMPILED}
    (ROOT / "liftd" / SOURCES).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    print(f"compile_core: {len(COMPILED)} modules compiled", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
