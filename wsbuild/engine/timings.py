"""Where a build's time goes: per-package phase times, the wall time against its lower bound,
and the recorded durations the scheduler weighs packages by.

- `TimingCollector` listens to the run's events and notes, per package, when it became ready
  (its last dependency finished), when it started, when each labelled step started and when it
  finished. "idle" is ready → started: the package waited for a worker (the CPU budget).
- `cpu_times()` is the CPU used by wsbuild and every child process it waited for (compilers
  run by make, Ninja, ccache, or by the sccache server wsbuild runs as its own child).
  limit = that CPU time ÷ cores: the lower bound of the wall time (every core busy throughout).
- Every run writes `timings.json` and `timings.txt` into its log directory; `--timings` prints
  the table too. `job_budget` is what the jobserver held; a distributed run adds
  `compile_jobs` (how many compiles ran remotely, locally, fell back; hosts lost). Packages
  built in the run record their durations in `build/.wsbuild/durations.json`, the
  scheduler's weights next time (builder/weights.py).
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.engine.jobs import JobEvent, JobFinished, JobResult, JobStarted, Outcome, StepStarted
from wsbuild.engine.timing_files import (
    TIMINGS_JSON,
    TIMINGS_TEXT,
    cpu_seconds,
    critical_chain,
    limit,
    summary_line,
    totals_json,
    write_timing_files,
)
from wsbuild.files import atomic_write
from wsbuild import inputs

if TYPE_CHECKING:  # what only a build that ran packages has: a no-op imports none of it
    from wsbuild.engine.memory import MemoryUse

__all__ = ["TIMINGS_JSON", "TIMINGS_TEXT"]

#: under the build base: each package's duration the last time it was built
DURATIONS_FILE = Path(".wsbuild") / "durations.json"

def read_durations(build_base: Path) -> dict[str, float]:
    """Recorded durations (seconds) by package; empty when none or unreadable."""
    try:
        data = json.loads(inputs.read_text(build_base / DURATIONS_FILE))
    except (OSError, ValueError):
        return {}
    if not isinstance(data, dict):
        return {}
    return {str(k): float(v) for k, v in data.items() if isinstance(v, (int, float)) and v >= 0}


def record_durations(build_base: Path, results: Iterable[JobResult],
                     waited: Mapping[str, float] | None = None) -> None:
    """Keep the durations of packages built in this run (others keep their earlier record),
    less the seconds they `waited` for memory (a wait says nothing of the work)."""
    waited = waited or {}
    built = {r.package: round(max(0.0, r.seconds - waited.get(r.package, 0.0)), 3)
             for r in results if r.outcome is Outcome.FINISHED}
    if not built:
        return
    durations = read_durations(build_base)
    durations.update(built)
    path = build_base / DURATIONS_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, json.dumps(dict(sorted(durations.items())), indent=1) + "\n")


@dataclass(frozen=True, slots=True)
class CpuTimes:
    """user + system seconds."""

    children: float
    own: float

    @property
    def total(self) -> float:
        return self.children + self.own

    def __sub__(self, other: CpuTimes) -> CpuTimes:
        return CpuTimes(self.children - other.children, self.own - other.own)


def cpu_times() -> CpuTimes:
    return CpuTimes(*cpu_seconds())


def cpu_count() -> int:
    """The cores this process may run on (the run's CPU budget by default)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


@dataclass(frozen=True, slots=True)
class PackageTiming:
    """One package's times, in seconds since the start of the run."""

    package: str
    outcome: str
    ready: float
    started: float
    finished: float
    #: (label, start, end) of each labelled step; "check" is the up-to-date check before them
    phases: tuple[tuple[str, float, float], ...] = ()

    @property
    def idle(self) -> float:
        return max(0.0, self.started - self.ready)

    def phase_seconds(self) -> dict[str, float]:
        totals: dict[str, float] = {}
        for label, start, end in self.phases:
            totals[label] = totals.get(label, 0.0) + (end - start)
        return totals


@dataclass(slots=True)
class _Open:
    """A package's job while it runs: when it started, its steps so far."""

    started: float
    steps: list[tuple[str, float]] = field(default_factory=list)


class TimingCollector:
    """Notes the times of the run's events (pass it every event; it is thread-safe)."""

    def __init__(self, dependencies: Mapping[str, Iterable[str]]) -> None:
        self.start = time.monotonic()
        self._dependencies = {name: set(deps) for name, deps in dependencies.items()}
        self._open: dict[str, _Open] = {}
        self._done: dict[str, tuple[float, str]] = {}
        self._rows: dict[str, PackageTiming] = {}
        self._lock = threading.Lock()

    def __call__(self, event: JobEvent | object) -> None:
        now = time.monotonic() - self.start
        with self._lock:
            if isinstance(event, JobStarted):
                self._open[event.package] = _Open(now)
            elif isinstance(event, StepStarted) and event.package in self._open:
                self._open[event.package].steps.append((event.label, now))
            elif isinstance(event, JobFinished):
                self._finish(event.result, now)

    def _finish(self, result: JobResult, now: float) -> None:
        name = result.package
        self._done[name] = (now, result.outcome.value)
        opened = self._open.pop(name, None)
        if opened is None:  # skipped: never started
            return
        ready = max((self._done[d][0] for d in self._dependencies.get(name, ())
                     if d in self._done), default=0.0)
        marks = [("check", opened.started), *opened.steps, ("", now)]
        phases = tuple((label, start, marks[i + 1][1])
                       for i, (label, start) in enumerate(marks[:-1]))
        self._rows[name] = PackageTiming(name, result.outcome.value, min(ready, opened.started),
                                         opened.started, now, phases)

    def rows(self) -> list[PackageTiming]:
        """Started packages, in the order they started."""
        with self._lock:
            return sorted(self._rows.values(), key=lambda r: (r.started, r.package))


@dataclass(frozen=True, slots=True)
class CompileJobs:
    """Where a distributed run's compile jobs ran (counted from distcc's client log)."""

    remote: int
    local: int
    #: of the local ones: jobs that failed to distribute and were compiled here instead
    fell_back: int
    #: the remote hosts the run sent to
    hosts: tuple[str, ...] = ()
    #: hosts that failed during the run (their slots left the job budget)
    lost: tuple[str, ...] = ()

    def as_json(self) -> dict[str, object]:
        return {"remote": self.remote, "local": self.local, "fell_back": self.fell_back,
                "hosts": list(self.hosts), "lost": list(self.lost)}

    def summary(self) -> str:
        fell = f" ({self.fell_back} after failing to distribute)" if self.fell_back else ""
        hosts = ", ".join(self.hosts)
        lost = f"; lost during the run: {', '.join(self.lost)}" if self.lost else ""
        return (f"distributed compiles: {self.remote} of {self.remote + self.local} ran "
                f"remotely ({hosts}), {self.local} locally{fell}{lost}")


@dataclass(frozen=True, slots=True)
class RunTimings:
    """The times of a whole run: wall and CPU time, cores, each package's phases."""

    wall: float
    cpu: CpuTimes
    cores: int
    packages: tuple[PackageTiming, ...]
    #: with --distribute: where the compiles ran; None otherwise
    compile_jobs: CompileJobs | None = None
    #: the jobs the run's jobserver held (the cores, plus remote slots when distributing);
    #: 0: the cores
    job_budget: int = 0
    #: what the run used of its memory budget (None: no budget, or nothing ran)
    memory: MemoryUse | None = None

    @property
    def limit(self) -> float:
        """The wall time if every core were busy for the whole run: CPU seconds ÷ cores."""
        return limit(self.cpu.children, self.cpu.own, self.cores)

    def as_json(self) -> dict[str, object]:
        return {
            **totals_json(self.wall, self.cpu.children, self.cpu.own, self.cores),
            "cores": self.cores,
            "job_budget": self.job_budget or self.cores,
            "packages": [
                {"package": p.package, "outcome": p.outcome, "ready": round(p.ready, 3),
                 "started": round(p.started, 3), "finished": round(p.finished, 3),
                 "idle": round(p.idle, 3),
                 "phases": [[label, round(start, 3), round(end, 3)]
                            for label, start, end in p.phases]}
                for p in self.packages
            ],
            **({"compile_jobs": self.compile_jobs.as_json()} if self.compile_jobs else {}),
            **({"memory": self.memory.as_json()} if self.memory is not None else {}),
        }

    def summary_line(self) -> str:
        chain = critical_chain((p.package, p.ready, p.started, p.finished) for p in self.packages)
        return summary_line(self.wall, self.cpu.children, self.cpu.own, self.cores, chain)

    def table(self) -> list[str]:
        """Per built package: idle (waiting for the CPU budget), then its phases, in seconds."""
        rows = [p for p in self.packages if p.outcome != Outcome.UP_TO_DATE.value]
        labels: list[str] = []
        for p in rows:
            for label, _, _ in p.phases:
                if label not in labels:
                    labels.append(label)
        width = max([len("package"), *(len(p.package) for p in rows)])
        head = f"{'package':<{width}}  {'idle':>7}" + "".join(f"  {lab:>9}" for lab in labels) \
            + f"  {'total':>8}"
        lines = [head]
        for p in rows:
            seconds = p.phase_seconds()
            cells = "".join(f"  {seconds[lab]:>9.2f}" if lab in seconds else f"  {'-':>9}"
                            for lab in labels)
            lines.append(f"{p.package:<{width}}  {p.idle:>7.2f}{cells}  "
                         f"{p.finished - p.started:>8.2f}")
        return lines


def write_timings(run_log: Path, timings: RunTimings) -> None:
    """`timings.json` (machine-readable) and `timings.txt` (the table) in the run's log."""
    extra = [timings.compile_jobs.summary()] if timings.compile_jobs else []
    # the memory lines (every package's peak) before the summary line, which ends the file
    memory = timings.memory.summary(largest=len(timings.memory.packages)) \
        if timings.memory is not None else []
    write_timing_files(run_log, timings.as_json(),
                       [*timings.table(), "", *memory, timings.summary_line(), *extra])
