"""What each package's build needed in memory, kept beside the recorded durations
(`build/.wsbuild/memory.json`, as engine/timings.py keeps `durations.json`): per package its
peak (all its processes at once) and, per labelled step, the peak of one job under its make or
Ninja and of the step's processes, with how many jobs were measured, in the order the steps ran. The memory governor
(engine/memory.py) predicts from it; a CI matrix shares it through the cache server as it
shares the times (builder/shards/run.py).

A build that measured fewer than half the jobs of a step the record measured (an incremental
build compiling one file) only raises that step's figures; one that measured as many replaces
them (code that got smaller needs less).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild import inputs
from wsbuild.engine.memory_admission import Need
from wsbuild.files import atomic_write

#: under the build base, beside durations.json
MEMORY_FILE = Path(".wsbuild") / "memory.json"


#: what a make or Ninja and `cmake --build` hold around the first job of a step
DRIVER_OVERHEAD = 32 * 1024 * 1024


@dataclass(frozen=True, slots=True)
class StepMemory:
    """One labelled step of a package: the peak of its processes, of one of its jobs under a
    make or Ninja (None: it ran none), and how many such jobs were measured."""

    tree: int = 0
    job: int | None = None
    jobs: int = 0

    @property
    def start(self) -> int:
        """What the step takes to start: its processes' peak, or with a make or Ninja, its
        first job and the driver around it."""
        return self.tree if self.job is None else min(self.tree, self.job + DRIVER_OVERHEAD)

    def as_json(self) -> dict[str, object]:
        return {"tree": self.tree, "job": self.job, "jobs": self.jobs}


@dataclass(frozen=True, slots=True)
class PackageMemoryRecord:
    """A package's memory: its peak, and its steps' by label, in the order they ran."""

    peak: int = 0
    steps: Mapping[str, StepMemory] = field(default_factory=dict)

    @property
    def largest(self) -> int:
        """Its largest need: its peak, or any step's or job's."""
        return max([self.peak, *(s.tree for s in self.steps.values()),
                    *(s.job or 0 for s in self.steps.values())])

    @property
    def job(self) -> int | None:
        """The peak of its largest job (None: it ran none under a make or Ninja)."""
        jobs = [s.job for s in self.steps.values() if s.job is not None]
        return max(jobs) if jobs else None

    def need(self, label: str | None = None) -> Need:
        """What the package needs to start (`label` None: its first step), or its step
        `label` (a step never recorded: the package's largest need)."""
        if label is None:
            first = next((s for s in self.steps.values() if s.tree), None)
            return Need(self.job, first.start if first is not None else self.largest, True)
        step = self.steps.get(label)
        if step is None:
            return Need(None, self.largest, True)
        return Need(step.job, step.start, True)

    def need_ahead(self, label: str) -> Need:
        """What the package needs from its step `label` to its end: the largest start of
        that step and those after it (a step never recorded: the package's largest), and a
        job's peak in `label`."""
        labels = list(self.steps)
        if label not in labels:
            return Need(None, self.largest, True)
        ahead = [self.steps[name] for name in labels[labels.index(label):]]
        return Need(self.steps[label].job, max(step.start for step in ahead), True)

    def as_json(self) -> dict[str, object]:
        return {"peak": self.peak,
                "steps": {label: step.as_json() for label, step in self.steps.items()}}


def record_from_json(data: object) -> PackageMemoryRecord | None:
    """A record as `as_json` wrote it (None: not one)."""
    if not isinstance(data, dict) or not isinstance(data.get("peak"), int):
        return None
    steps: dict[str, StepMemory] = {}
    raw = data.get("steps")
    for label, step in (raw.items() if isinstance(raw, dict) else ()):
        if not isinstance(step, dict):
            continue
        tree, job, jobs = step.get("tree"), step.get("job"), step.get("jobs")
        if isinstance(tree, int) and (job is None or isinstance(job, int)) \
                and isinstance(jobs, int):
            steps[str(label)] = StepMemory(tree, job, jobs)
    return PackageMemoryRecord(int(data["peak"]), steps)


def records_from_json(data: object) -> dict[str, PackageMemoryRecord]:
    found: dict[str, PackageMemoryRecord] = {}
    for name, value in (data.items() if isinstance(data, dict) else ()):
        record = record_from_json(value)
        if record is not None:
            found[str(name)] = record
    return found


def read_memory(build_base: Path) -> dict[str, PackageMemoryRecord]:
    """The recorded memory of each package; empty when none or unreadable."""
    try:
        return records_from_json(json.loads(inputs.read_text(build_base / MEMORY_FILE)))
    except (OSError, ValueError):
        return {}


def merged(old: PackageMemoryRecord | None, new: PackageMemoryRecord) -> PackageMemoryRecord:
    """`new` over `old`, step by step (see the module)."""
    if old is None:
        return new
    steps = dict(old.steps)
    for label, step in new.steps.items():
        before = steps.get(label)
        if before is None or step.jobs * 2 >= before.jobs:
            steps[label] = step
        else:
            steps[label] = StepMemory(max(step.tree, before.tree),
                                      max(step.job or 0, before.job or 0) or None, before.jobs)
    peak = max([new.peak, *(s.tree for s in steps.values())])
    return PackageMemoryRecord(peak, steps)


def record_memory(build_base: Path, measured: Mapping[str, PackageMemoryRecord]) -> None:
    """Keep what the packages built in this run needed (others keep their earlier record)."""
    if not measured:
        return
    records = read_memory(build_base)
    for name, record in measured.items():
        records[name] = merged(records.get(name), record)
    path = build_base / MEMORY_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, json.dumps({name: records[name].as_json() for name in sorted(records)},
                                  indent=1) + "\n")
