"""A run's `timings.json` and `timings.txt`: their names, their totals and summary line, and
writing them. Kept apart from engine/timings.py (the recorder and its types) so that a replayed
no-op (builder/noop.py) writes them without importing the rest."""

from __future__ import annotations

import json
import resource
import time
from pathlib import Path

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
    """The wall time if every core were busy for the whole run: CPU seconds ÷ cores."""
    return (children + own) / max(1, cores)


def totals_json(wall: float, children: float, own: float, cores: int) -> dict[str, object]:
    """The run's totals as timings.json holds them."""
    return {"wall_seconds": round(wall, 3),
            "cpu_seconds": {"children": round(children, 3), "wsbuild": round(own, 3),
                            "total": round(children + own, 3)},
            "limit_seconds": round(limit(children, own, cores), 3)}


def summary_line(wall: float, children: float, own: float, cores: int) -> str:
    most = limit(children, own, cores)
    ratio = f" ({wall / most:.2f}× the limit)" if most > 0 else ""
    return (f"CPU {children + own:.1f} s (wsbuild {own:.1f} s) on {cores} "
            f"cores: limit {most:.1f} s, wall {wall:.1f} s{ratio}")


def write_timing_files(run_log: Path, data: dict[str, object], lines: list[str]) -> None:
    """`timings.json` (`data`) and `timings.txt` (`lines`) in the run's log."""
    run_log.mkdir(parents=True, exist_ok=True)
    (run_log / TIMINGS_JSON).write_text(json.dumps(data, indent=1) + "\n")
    (run_log / TIMINGS_TEXT).write_text("\n".join(lines) + "\n")
