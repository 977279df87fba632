"""The memory governor: admits packages and hands out jobserver tokens so that what runs plus
what it is predicted to take next fits the run's memory budget (engine/memory_budget.py), by
the rule of engine/memory_admission.py.

It holds every token of the run's jobserver (engine/jobserver.py) and, every `interval`
seconds, measures the build's process tree (engine/memory_tree.py: each package's processes,
each job under a make or Ninja), reads the free memory (the live guard), learns from what it
measured (a job's peak when it ends, per package and step) and hands out or takes back tokens.
The scheduler (engine/schedule.py) asks it before starting a package, and each command step
of a package asks it before it starts (`wait_for_step`); among those asking, the scheduler's
order decides (see `_state`). A step is never killed for memory: a package that cannot fit
even alone runs alone, and the governor says so (`warn`), as it says when free memory fell
below the margin.

At the end (`stop`) it tells what the run used (`MemoryUse`): the budget, the tree's peak, each
package's peak and what each step needed (the records of engine/memory_records.py), how long
packages waited to start and how many token-seconds were held back for memory.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass, field

from wsbuild.engine.jobs import JobEvent, JobFinished, JobStarted, StepStarted
from wsbuild.engine.jobserver import Jobserver
from wsbuild.engine.memory_admission import (
    MemoryState,
    Need,
    Running,
    may_start,
    tokens_wanted,
)
from wsbuild.engine.memory_budget import MemoryBudget, format_size, free_memory
from wsbuild.engine.memory_records import PackageMemoryRecord, StepMemory
from wsbuild.engine.memory_tree import TreeSnapshot, snapshot
from wsbuild.engine.process import REGISTRY, ProcessRegistry

INTERVAL = 0.1
#: what a package or job never measured is taken to need when the budget holds that much for
#: every job the run can start at once (each package's implicit slot and every token):
#: memory is then plentiful, and nothing waits to be measured first (a heavy C++ compile, an
#: rclcpp or a PCL user, takes 1-2 GiB; the live guard still holds tokens back if free
#: memory runs low)
PLENTIFUL_JOB = 2 * 1024**3
#: the label of the phase in which a step waits for memory (timings, the status line)
WAIT_LABEL = "wait for memory"
#: how often a waiting step asks again
_STEP_POLL = 0.05


@dataclass(slots=True)
class _StepMeasure:
    """What a running step was measured at: its tree's memory, its largest job, its jobs."""

    tree: int = 0
    job: int = 0
    jobs: int = 0


@dataclass(slots=True)
class _Package:
    """What the governor measured of one package in this run."""

    peak: int = 0
    label: str = ""
    steps: dict[str, _StepMeasure] = field(default_factory=dict)
    #: jobs running now: pid → (its step's label, its peak so far)
    open_jobs: dict[int, tuple[str, int]] = field(default_factory=dict)
    waited: float = 0.0
    #: of it, the seconds its steps waited (inside its build's duration)
    waited_in_steps: float = 0.0

    def step(self, label: str) -> _StepMeasure:
        return self.steps.setdefault(label, _StepMeasure())

    def close_jobs(self, still: Collection[int] = ()) -> None:
        for pid in [p for p in self.open_jobs if p not in still]:
            label, peak = self.open_jobs.pop(pid)
            step = self.step(label)
            step.job = max(step.job, peak)
            step.jobs += 1

    def record(self) -> PackageMemoryRecord:
        """What it measured, every labelled step (one that ran in wsbuild's own process holds
        nothing: a package between its steps needs no room for it)."""
        return PackageMemoryRecord(self.peak, {
            label: StepMemory(s.tree, s.job if s.jobs else None, s.jobs)
            for label, s in self.steps.items() if label})


@dataclass(frozen=True, slots=True)
class MemoryUse:
    """What a run used of its budget."""

    budget: MemoryBudget
    #: the build's process tree at its largest (wsbuild's own process included)
    peak: int
    #: each package's peak, and what each of its steps needed
    packages: Mapping[str, PackageMemoryRecord]
    #: seconds each package waited for memory, to start or before a step
    waited: Mapping[str, float]
    #: token-seconds held back for memory while a make or Ninja ran
    held_back: float
    #: packages that could not fit beside others and ran alone
    alone: tuple[str, ...] = ()
    #: of `waited`, the seconds spent before a step (part of the package's duration)
    in_steps: Mapping[str, float] = field(default_factory=dict)

    def as_json(self) -> dict[str, object]:
        return {"budget": self.budget.as_json(), "peak": self.peak,
                "waited_seconds": round(sum(self.waited.values()), 3),
                "held_back_token_seconds": round(self.held_back, 3),
                "alone": list(self.alone),
                "packages": {name: {**record.as_json(),
                                    "waited": round(self.waited.get(name, 0.0), 3)}
                             for name, record in sorted(self.packages.items())}}

    def summary(self, largest: int = 5) -> list[str]:
        """The summary's lines: budget and peak, the waits, the largest packages."""
        waited = sum(self.waited.values())
        lines = [f"memory: budget {self.budget.text()}; the build peaked at "
                 f"{format_size(self.peak)}"]
        if waited or self.held_back:
            lines.append(f"waited for memory: packages {waited:.1f} s (to start, or before a "
                         f"step), {self.held_back:.1f} token-seconds of jobs held back")
        ranked = sorted(self.packages.items(), key=lambda item: (-item[1].peak, item[0]))
        ranked = [(n, r) for n, r in ranked if r.peak]
        if ranked:
            shown = ", ".join(f"{n} {format_size(r.peak)}" for n, r in ranked[:largest])
            more = f" (and {len(ranked) - largest} more: timings.txt)" \
                if len(ranked) > largest else ""
            lines.append(f"peak memory by package: {shown}{more}")
        return lines


class MemoryGovernor:
    """One run's memory admission (see the module). `predictions`: what each package is
    recorded to need; `light`: packages whose job needs no memory of its own (a restore)."""

    def __init__(self, budget: MemoryBudget, jobserver: Jobserver,
                 predictions: Mapping[str, PackageMemoryRecord], *,
                 warn: Callable[[str], None], light: Collection[str] = (),
                 interval: float = INTERVAL, registry: ProcessRegistry = REGISTRY,
                 root: int | None = None,
                 read_free: Callable[[], int | None] | None = None,
                 workers: int | None = None) -> None:
        self.budget = budget
        #: what a package never recorded is taken to need (None: it is measured first), see
        #: PLENTIFUL_JOB; `workers`: the packages that may run at once (None: as many as jobs)
        slots = jobserver.tokens + (workers if workers is not None else jobserver.tokens + 1)
        self.prior = PLENTIFUL_JOB if budget.bytes >= PLENTIFUL_JOB * slots else None
        self.jobserver = jobserver
        self._recorded = dict(predictions)
        self._light = frozenset(light)
        self._warn = warn
        self.interval = interval
        self._registry = registry
        self._root = os.getpid() if root is None else root
        self._read_free = read_free or (lambda: free_memory(budget))
        self._lock = threading.Lock()
        self._balancing = threading.Lock()
        self._running: dict[str, float] = {}
        self._measured: dict[str, _Package] = {}
        self._refused: dict[str, float] = {}
        #: steps waiting to start (wait_for_step) → what they need
        self._pending: dict[str, Need] = {}
        #: packages never recorded whose step (its label) started, none of its jobs measured
        self._measuring: dict[str, str] = {}
        self._snapshot = TreeSnapshot(0)
        self._low = False
        self._peak = 0
        self._held_back = 0.0
        self._alone: list[str] = []
        self._said: set[str] = set()
        self._to_say: list[str] = []
        self._stopped = threading.Event()
        self._thread: threading.Thread | None = None
        self._last_tick = 0.0

    # ------------------------------------------------------------------ the scheduler's side

    def start(self) -> MemoryGovernor:
        self.jobserver.hold()
        self._tick()
        self._thread = threading.Thread(target=self._run, name="wsbuild-memory", daemon=True)
        self._thread.start()
        return self

    def may_start(self, name: str) -> bool:
        """Whether `name` may start now (the scheduler asks before it starts a package)."""
        return self._admit(name, None)

    def wait_for_step(self, name: str, label: str, emit: Callable[[JobEvent], None]) -> None:
        """Return when the step `label` of the running package `name` may start: while it may
        not, it holds room for what it needs (no token goes to others meanwhile) and its
        package is in the phase WAIT_LABEL (`emit`). Never waits once the run is cancelled."""
        if self._admit(name, label):
            return
        emit(StepStarted(name, WAIT_LABEL))
        began = time.monotonic()
        while not self._stopped.is_set() and not self._registry.cancelled.is_set():
            time.sleep(_STEP_POLL)
            if self._admit(name, label):
                break
        waited = time.monotonic() - began
        with self._lock:
            self._pending.pop(name, None)
            package = self._measured.setdefault(name, _Package())
            package.waited += waited
            package.waited_in_steps += waited

    def _admit(self, name: str, label: str | None) -> bool:
        """The rule's verdict for the package `name` (`label` None) or its step `label`; a
        step refused holds room for what it needs until it starts."""
        with self._lock:
            need = self._need(name, label)
            verdict = may_start(self._state(waiter=name), name, need)
            if verdict.start and verdict.alone and name not in self._alone:
                self._alone.append(name)
                self._say(name, f"{name} is predicted to need {format_size(need.start or 0)}"
                          f"{f' in its step {label}' if label else ''}, more than the memory "
                          f"budget of {format_size(self.budget.bytes)} leaves beside wsbuild: "
                          "it runs alone, its jobs one at a time")
            if label is not None:
                if verdict.start:
                    self._pending.pop(name, None)
                    if not need.known and need.job is None:
                        self._measuring[name] = label  # until one of its jobs is measured
                    if name in self._measured:  # its step is this one from now on
                        self._measured[name].label = label
                        self._measured[name].step(label)
                else:
                    self._pending[name] = need
            elif not verdict.start:
                self._refused.setdefault(name, time.monotonic())
        if label is not None and verdict.start:
            # the tokens out were handed out for what ran before (a configure's small jobs):
            # before this step's make or Ninja can take them, only what it allows stays out
            self._balance_tokens()
        self._flush()
        return verdict.start

    def hear(self, event: JobEvent | object) -> None:
        """The run's events: a package started (its wait ends), a step started (its label), a
        package finished."""
        if isinstance(event, JobFinished):
            self._finished(event.result.package)
        elif isinstance(event, JobStarted):
            with self._lock:
                now = time.monotonic()
                self._running[event.package] = now
                package = self._measured.setdefault(event.package, _Package())
                refused = self._refused.pop(event.package, None)
                if refused is not None:
                    package.waited += now - refused
        elif isinstance(event, StepStarted):
            with self._lock:
                if event.package in self._measured and event.label != WAIT_LABEL:
                    package = self._measured[event.package]
                    package.label = event.label
                    package.step(event.label)
                    if self._measuring.get(event.package, event.label) != event.label:
                        del self._measuring[event.package]  # that step ended

    def _finished(self, name: str) -> None:
        """`name` ended: its open jobs are measured, it holds nothing any more."""
        with self._lock:
            self._running.pop(name, None)
            package = self._measured.get(name)
            if package is not None:
                package.close_jobs()
            self._refused.pop(name, None)
            self._pending.pop(name, None)
            self._measuring.pop(name, None)

    def stop(self) -> MemoryUse:
        """Stop measuring (the tokens stay held: the run's packages are done)."""
        self._stopped.set()
        if self._thread is not None:
            self._thread.join()
        with self._lock:
            return MemoryUse(
                self.budget, self._peak,
                {name: p.record() for name, p in self._measured.items() if p.peak},
                {name: p.waited for name, p in self._measured.items() if p.waited},
                self._held_back, tuple(self._alone),
                {name: p.waited_in_steps for name, p in self._measured.items()
                 if p.waited_in_steps})

    # ------------------------------------------------------------------ predictions

    def _need(self, name: str, label: str | None = None, *, ahead: bool = False) -> Need:
        """What `name` needs to start (`label` None or ""), or its step `label` (`ahead`: and
        the steps after it): as recorded, with a job's peak raised by what this run measured
        of that step's jobs; a package never recorded is unknown; a restore needs nothing to
        start (a restore that builds after all has steps, which need what its record says)."""
        if name in self._light and not label:
            return Need(0, 0, True)
        record = self._recorded.get(name)
        package = self._measured.get(name)
        step = package.steps.get(label) if package is not None and label else None
        measured = step.job if step is not None and step.jobs else None
        if record is None:
            if self.prior is not None:  # memory is plentiful: no need to measure it first
                return Need(max(measured or 0, self.prior), self.prior, True)
            return Need(measured, None, False)
        need = record.need_ahead(label) if ahead and label else record.need(label or None)
        if ahead and not label:  # before its first step: all of them are ahead
            need = Need(need.job, record.largest, True)
        if measured is not None:
            need = Need(max(measured, need.job or 0), need.start, True)
        return need

    def _fallback(self) -> int | None:
        """The largest need known: of any package recorded, of a package that finished in
        this run, or of a job that ended in a step after a package's first (the jobs of its
        first, a configure's compiler checks, are no compiles)."""
        known = [r.largest for r in self._recorded.values()]
        for name, package in self._measured.items():
            if name in self._light:
                continue
            if name not in self._running:
                known.append(package.peak)
                continue
            ran = [step for step in package.steps.values() if step.tree or step.jobs]
            known += [step.job for step in ran[1:] if step.jobs]
        values = [v for v in known if v]
        return max(values) if values else None

    def _state(self, waiter: str | None = None) -> MemoryState:
        """What runs now, with what each running package is predicted to need.

        For the package or step `waiter` asking to start, the scheduler's priority decides (a
        package that started earlier came first in its order): a package that started before
        it holds room for what it needs from its step to its end (a waiting step: what that
        step needs), so a later one never takes the room of an earlier one's next step; one
        that started after it counts only with its processes, so that what waits the longest
        in that order is never held back by what waits behind it (two steps would wait for
        each other for ever). Without a `waiter` (the tokens), each holds what its step, or
        the step it waits to start, needs."""
        names = list(self._running)
        rank = names.index(waiter) if waiter in self._running else len(names)
        running = []
        for index, name in enumerate(names):
            if name == waiter:
                continue
            seen = self._snapshot.packages.get(name)
            label = self._measured[name].label if name in self._measured else None
            measuring = name in self._measuring and self.prior is None
            if waiter is not None and index > rank:  # behind it: its processes only
                if seen is None or not seen.rss:
                    continue
                need = self._need(name, label)
                need = Need(need.job, 0, need.known)
            else:
                need = self._need(name, label, ahead=waiter is not None)
                pending = self._pending.get(name)
                if pending is not None:
                    need = pending if waiter is None else Need(
                        pending.job, max(pending.start or 0, need.start or 0) or None,
                        pending.known)
            if seen is None:
                running.append(Running(name, need=need, measuring=measuring))
            else:
                running.append(Running(name, seen.rss, tuple(seen.jobs.values()), seen.driving,
                                       need, measuring))
        if waiter in self._running:  # what it holds now, in place of which its step asks
            seen = self._snapshot.packages.get(waiter)
            running.append(Running(waiter, seen.rss if seen is not None else 0))
        return MemoryState(self.budget.bytes, self._snapshot.total, tuple(running),
                           self.jobserver.circulating, self._fallback(), self._low)

    # ------------------------------------------------------------------ the tick

    def _run(self) -> None:
        while not self._stopped.wait(self.interval):
            self._tick()

    def _tick(self) -> None:
        now = time.monotonic()
        seen = snapshot(self._root, self._registry.owners())
        free = self._read_free()
        with self._lock:
            dt = now - self._last_tick if self._last_tick else 0.0
            self._last_tick = now
            self._snapshot = seen
            self._peak = max(self._peak, seen.total)
            low = free is not None and free < self.budget.margin
            if low and not self._low:
                self._say("", f"free memory fell to {format_size(free or 0)}, below the "
                          f"margin of {format_size(self.budget.margin)}: no new jobs start "
                          "until it recovers")
            self._low = low
            self._learn(seen)
        self._balance_tokens(dt)
        self._flush()

    def _balance_tokens(self, dt: float = 0.0) -> None:
        """Hand out or take back tokens as what runs now allows (`dt`: the seconds since the
        last tick, for the tokens held back). One caller at a time (the tick, a step's start):
        two that counted the same tokens out would both hand out the difference."""
        with self._balancing:
            with self._lock:
                state = self._state()
                capacity = self.jobserver.tokens - self.jobserver.withheld
                wanted = tokens_wanted(state, capacity)
                out = state.tokens_out
                if any(p.driving for p in state.running):
                    self._held_back += max(0, capacity - out) * dt
            if wanted > out:
                self.jobserver.release(wanted - out)
            elif wanted < out:
                self.jobserver.reclaim(out - wanted)

    def _learn(self, seen: TreeSnapshot) -> None:
        """Each running package's peak, its step's, and its jobs' (a job gone has ended)."""
        for name, memory in seen.packages.items():
            package = self._measured.setdefault(name, _Package())
            package.peak = max(package.peak, memory.rss)
            step = package.step(package.label)
            step.tree = max(step.tree, memory.rss)
            package.close_jobs(memory.jobs)
            for pid, rss in memory.jobs.items():
                label, peak = package.open_jobs.get(pid, (package.label, 0))
                package.open_jobs[pid] = (label, max(peak, rss))
        for name, package in self._measured.items():
            if name not in seen.packages:
                package.close_jobs()
        for name, label in list(self._measuring.items()):
            step = self._measured[name].steps.get(label) if name in self._measured else None
            if step is not None and step.jobs:
                del self._measuring[name]  # its first job is measured

    def _say(self, key: str, text: str) -> None:
        """Say `text` once per `key` (after the lock is released: see `_flush`)."""
        if key not in self._said:
            self._said.add(key)
            self._to_say.append(text)

    def _flush(self) -> None:
        with self._lock:
            said, self._to_say = self._to_say, []
        for text in said:
            self._warn(text)
