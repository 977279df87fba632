"""A run's `timings.json` and `timings.txt`: their names, their totals and summary line, and
writing them. Kept apart from engine/timings.py (the recorder and its types) so that a replayed
no-op (engine/replay.py) writes them without importing the rest."""

from __future__ import annotations

import json
import resource
import time
from collections.abc import Iterable, Sequence
from pathlib import Path

from wsbuild.redaction import redact

TIMINGS_JSON = "timings.json"
TIMINGS_TEXT = "timings.txt"


def cpu_seconds() -> tuple[float, float]:
    """user + system seconds of the processes this one waited for, and of this one."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    own = resource.getrusage(resource.RUSAGE_SELF)
    return children.ru_utime + children.ru_stime, own.ru_utime + own.ru_stime


def started_at(origin: float) -> str:
    """The wall-clock time (UTC) of the monotonic instant `origin`."""
    wall = time.time() - (time.monotonic() - origin)
    return time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(wall))


def limit(children: float, own: float, cores: int) -> float:
    """The lower bound of the run's wall time: CPU seconds ÷ cores (every core busy throughout)."""
    return (children + own) / max(1, cores)


def totals_json(wall: float, children: float, own: float, cores: int) -> dict[str, object]:
    """The run's totals as timings.json holds them (`limit_seconds`: the lower bound)."""
    return {"wall_seconds": round(wall, 3),
            "cpu_seconds": {"children": round(children, 3), "wsbuild": round(own, 3),
                            "total": round(children + own, 3)},
            "limit_seconds": round(limit(children, own, cores), 3)}


#: below this multiple of the lower bound a run used its cores well: no "why" is looked for
_WELL_USED = 1.2


def critical_chain(rows: Iterable[tuple[str, float, float, float]]) -> list[tuple[str, float]]:
    """The chain of packages that set the run's length, first to last, each with the seconds
    it ran: from the package that finished last, back through the one that finished when it
    became ready (its dependency that finished last). `rows`: (package, ready, started,
    finished) in seconds since the run started."""
    by_name = {name: (ready, started, finished) for name, ready, started, finished in rows}
    if not by_name:
        return []
    finished_at: dict[float, str] = {}
    for name in sorted(by_name):  # ties go to the first name
        finished_at.setdefault(by_name[name][2], name)
    current: str | None = max(sorted(by_name), key=lambda n: by_name[n][2])
    chain: list[tuple[str, float]] = []
    while current is not None and all(current != name for name, _ in chain):
        ready, started, finished = by_name[current]
        chain.append((current, finished - started))
        current = finished_at.get(ready) if ready > 0 else None
    return chain[::-1]


def bound_text(wall: float, cpu: float, cores: int,
               chain: Sequence[tuple[str, float]] = ()) -> str:
    """The run's wall time against its lower bound (CPU ÷ cores) and, when it was well above
    it and `chain` (critical_chain) says why, the why: `wall 10.7 s, 1.4× the lower bound of
    7.5 s (CPU ÷ cores): the critical path a → b ran one after another for 10.2 s`."""
    bound = cpu / max(1, cores)
    if bound <= 0:
        return f"wall {wall:.1f} s"
    text = f"wall {wall:.1f} s, {wall / bound:.1f}× the lower bound of {bound:.1f} s (CPU ÷ cores)"
    busy = sum(seconds for _, seconds in chain)
    if wall / bound < _WELL_USED or busy <= 0:
        return text
    if len(chain) == 1:
        return text + f": {chain[0][0]} alone ran for {busy:.1f} s of it"
    path = " → ".join(name for name, _ in chain)
    return text + f": the critical path {path} ran one after another for {busy:.1f} s of it"


def summary_line(wall: float, children: float, own: float, cores: int,
                 chain: Sequence[tuple[str, float]] = ()) -> str:
    """The last line of timings.txt (and of --timings): CPU, wall and why (bound_text)."""
    return (f"CPU {children + own:.1f} s (wsbuild {own:.1f} s) on {cores} cores; "
            + bound_text(wall, children + own, cores, chain))


def write_timing_files(run_log: Path, data: dict[str, object], lines: list[str]) -> None:
    """`timings.json` (`data`) and `timings.txt` (`lines`) in the run's log."""
    run_log.mkdir(parents=True, exist_ok=True)
    # (without an indent: the standard library's C encoder, a tenth of the time for 1,000
    # packages; timings.txt is the one for reading)
    (run_log / TIMINGS_JSON).write_text(redact(json.dumps(data, separators=(",", ":"))) + "\n")
    (run_log / TIMINGS_TEXT).write_text(redact("\n".join(lines)) + "\n")
