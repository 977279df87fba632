"""One run of package jobs, the same for `wsbuild build` and `wsbuild test`: in the run's
session the scheduler (engine/schedule.py) starts the jobs as its ready queue hands them out
while the run's timings (engine/timings.py) and CPU samples are taken; at the end
`timings.json`/`timings.txt` and the report (`report.json`, `report.html`) go into the run's
log directory."""

from __future__ import annotations

import time
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.engine.ready_queue import JobGraph
from wsbuild.engine.schedule import FailurePolicy, Job, run_jobs
from wsbuild.engine.timings import (
    CompileJobs,
    CpuTimes,
    RunTimings,
    TimingCollector,
    cpu_times,
    write_timings,
)
from wsbuild.runreport import write
from wsbuild.runreport.report_json import RunFacts
from wsbuild.runreport.write import start_sampler

if TYPE_CHECKING:
    from wsbuild.engine.memory import MemoryGovernor, MemoryUse
    from wsbuild.events import Emit, Event
    from wsbuild.workspace.selection import Selection


@dataclass(frozen=True, slots=True)
class RunEnd:
    """What the end of a run wrote: its timings, and the report page's path (None: not
    drawn), or why the report was not written."""

    timings: RunTimings
    report: Path | str | None


class PackageRun:
    """One run's jobs, timings and report. Make it when the run's clock starts (`started`,
    `cpu_before`: earlier, when the run began before its session), pass every event through
    `timed()` (or run the jobs with `run()`), and call `finish()` once at the end, also after
    Ctrl-C."""

    def __init__(self, selection: Selection, run_log: Path, jobs: JobGraph, *, report: bool,
                 sample_cpu: bool = True, started: float | None = None,
                 cpu_before: CpuTimes | None = None) -> None:
        self.selection = selection
        self.run_log = run_log
        #: every package of the run (settled without a worker or not): when each became ready
        self.jobs = jobs
        self.started = time.monotonic() if started is None else started
        self.cpu_before = cpu_times() if cpu_before is None else cpu_before
        self.recorder = TimingCollector(jobs.dependencies)
        # the report's CPU curve: nothing to sample when no job needs a worker
        self.sampler = start_sampler(report and sample_cpu, self.recorder.start)
        #: the memory governor of the packages that run (engine/memory.py); None: no budget
        self.memory: MemoryGovernor | None = None

    def timed(self, emit: Emit) -> Emit:
        """`emit`, with each event noted in the run's timings (and by the memory governor)
        first."""
        def both(event: Event) -> None:
            self.recorder(event)
            if self.memory is not None:
                self.memory.hear(event)
            emit(event)

        return both

    def run(self, jobs: JobGraph, job: Job, *, workers: int, policy: FailurePolicy,
            emit: Emit, weights: Mapping[str, float] | None = None,
            waiting: Collection[str] = ()) -> list[JobResult]:
        """The scheduler over `jobs` (the run's, or those of them that need a worker), its
        events timed; Ctrl-C comes out as engine/schedule.py's RunInterrupted. `waiting`: the
        jobs that take no worker while they wait for another machine. With a memory
        governor, it admits each package."""
        return run_jobs(jobs, job, workers=workers, policy=policy, emit=self.timed(emit),
                        weights=weights, waiting=waiting,
                        admit=self.memory.may_start if self.memory is not None else None)

    def finish(self, results: Sequence[JobResult], facts: RunFacts, *,
               extra: Mapping[str, Mapping[str, object]] | None = None,
               compile_jobs: CompileJobs | None = None, job_budget: int = 0,
               memory: MemoryUse | None = None) -> RunEnd:
        """timings.json/txt (always), then unless `facts` turn the report off report.json and
        report.html; a build where every package was up to date draws its page only when
        asked (--timings, or later `wsbuild report`): a no-op stays quick."""
        self.sampler.stop()
        timings = RunTimings(time.monotonic() - self.started, cpu_times() - self.cpu_before,
                             facts.cores, tuple(self.recorder.rows()),
                             compile_jobs=compile_jobs, job_budget=job_budget, memory=memory)
        try:
            write_timings(self.run_log, timings)
        except OSError as exc:
            return RunEnd(timings, f"timings not written: {exc.strerror or exc}")
        if not facts.report:
            return RunEnd(timings, None)
        no_op = facts.verb == "build" and all(r.outcome is Outcome.UP_TO_DATE
                                                   for r in results)
        # looked up when called: a test times the report's writing by replacing it
        written = write.write_run_report(self.selection, facts, self.run_log, self.jobs,
                                         results, self.sampler,
                                         page=facts.timings or not no_op, extra=extra)
        return RunEnd(timings, written)
