"""Digests of what the GEO core computes, cycle by cycle, on a fixed set of runs: the compiled
core (mypyc) must give the same bits as the Python source (tests/unit/cnc/test_compiled.py).

`python -m tests.support.core_digest` prints them as JSON; the test runs it once in a
subprocess on a copy of the source without the extensions, and once in-process."""

from __future__ import annotations

import hashlib
import io
import json
from collections.abc import Iterator

from liftd.cnc.params import LiftMethod
from liftd.cnc.plc import Schedule
from tests.support.closed_loop import run_task
from tests.support.paths import REPO
from tests.support.programs import nesting_program
from tests.support.scenarios import scenario, wide_scenario

# random closed-loop runs: the wide ones that once found late lifts, and plain ones with both
# lift methods; the demo; a nesting job under an override schedule with feed holds
WIDE = (388, 890, 983, 1747)
PLAIN = (0, 1, 2)


def _cases() -> Iterator[tuple[str, object, str, Schedule]]:
    from liftd.settings import load_settings  # noqa: PLC0415

    ch = load_settings(str(REPO / "config" / "liftd.toml")).channel
    yield "demo", ch, (REPO / "config" / "programs" / "demo.nc").read_text(), Schedule()
    steps = (0.6, 0.8, 1.0, 1.5, 2.0, 0.0, 1.2)
    override = tuple((0.37 * (k + 1), steps[k % len(steps)]) for k in range(120))
    holds = ((5.0, 5.5), (11.0, 11.2))
    yield "nesting", ch, nesting_program(20), Schedule(override=override, feed_hold=holds)
    for seed in WIDE:
        sc = wide_scenario(seed)
        yield f"wide{seed}", sc.channel, sc.text, sc.schedule
    for seed in PLAIN:
        for method in (LiftMethod.ADVANCED, LiftMethod.LIFTING):
            sc = scenario(seed, method)
            yield f"s{seed}-{method.name}", sc.channel, sc.text, sc.schedule


def digests() -> dict[str, str]:
    """Every snapshot of each case, and `simulate`'s trace CSV and JSON summary of the first
    two (its per-cycle part is compiled too; the step timing excluded)."""
    from liftd.sim.simulate import simulate  # noqa: PLC0415

    out = {}
    for i, (name, ch, text, schedule) in enumerate(_cases()):
        _, snaps = run_task(ch, text, schedule, max_time=300.0)  # type: ignore[arg-type]
        h = hashlib.sha256()
        for s in snaps:
            h.update(repr(s).encode())  # every field, floats to the last bit
        out[name] = f"{len(snaps)}:{h.hexdigest()}"
        if i < 2:
            trace = io.StringIO()
            res = simulate(ch, text, schedule, 0.02, trace)  # type: ignore[arg-type]
            summary = res.summary.to_json()
            summary.pop("step_cpu_us")
            h = hashlib.sha256(trace.getvalue().encode())
            h.update(json.dumps(summary, sort_keys=True).encode())
            out[f"{name} simulate"] = h.hexdigest()
    return out


if __name__ == "__main__":
    print(json.dumps(digests()))
