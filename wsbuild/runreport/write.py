"""What a run calls to get its report: a CPU sampler started with the run, and at its end
`report.json` then `report.html` in the run's log directory. A `wsbuild test` run, which does
not time itself, gets its timings recorded here too (`RunWatch`)."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.engine.cpu_sampler import CpuSampler
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.engine.progress import Progress
from wsbuild.engine.timings import (
    RunTimings,
    TimingCollector,
    cpu_times,
    read_durations,
    write_timings,
)
from wsbuild.runreport.report_json import BuildFacts, build_report_data, test_report_data, write_report_json

if TYPE_CHECKING:
    from wsbuild.events import Emit, Event
    from wsbuild.testing.results import TestRun
    from wsbuild.workspace.selection import Selection


def start_sampler(enabled: bool, origin: float) -> CpuSampler:
    """The run's CPU sampler (times since `origin`, the run's timing origin); one that records
    nothing when the report is off."""
    return CpuSampler.started(origin=origin) if enabled else CpuSampler(origin=origin)


def _written(run_log: Path, record: Mapping[str, object], *, page: bool = True
             ) -> Path | str | None:
    """report.json then (`page`) report.html; the page's path (None: not drawn), or why it
    was not written."""
    try:
        write_report_json(run_log, record)
        if not page:
            return None
        from wsbuild.runreport.page import write_report

        return write_report(run_log)
    except OSError as exc:
        return f"report not written: {exc.strerror or exc}"


def write_build_report(plan: Selection, facts: BuildFacts, run_log: Path,
                       results: Sequence[JobResult], sampler: CpuSampler) -> tuple[str, ...]:
    """At the end of `wsbuild build` (after timings.json): the report, unless --no-report.
    A no-op's page (every package up to date: nothing to show but their names) is drawn when
    asked for (--timings, `wsbuild report`); its report.json is written. The lines the
    summary ends with: the report's path with --timings, or why it failed."""
    samples = sampler.stop()
    if not facts.report:
        return ()
    no_op = all(r.outcome is Outcome.UP_TO_DATE for r in results)
    written = _written(run_log, build_report_data(plan, facts, run_log, results, samples,
                                             sampler.origin), page=facts.timings or not no_op)
    if isinstance(written, str):
        return (written,)
    return (f"report: {written}",) if facts.timings and written is not None else ()


class RunWatch:
    """The timings and CPU samples of a run that does not record them itself (wsbuild test):
    pass its events through `watching(emit)`."""

    def __init__(self, dependencies: Mapping[str, set[str]], *, enabled: bool) -> None:
        self.enabled = enabled
        self.recorder = TimingCollector(dependencies)
        self.cpu_before = cpu_times()
        self.sampler = start_sampler(enabled, self.recorder.start)

    def watching(self, emit: Emit) -> Emit:
        def both(event: Event) -> None:
            self.recorder(event)
            emit(event)

        return both


def write_test_report(plan: Selection, run: TestRun, workers: int, cores: int,
                      watch: RunWatch) -> Path | str | None:
    """At the end of `wsbuild test`: timings.json, report.json, report.html in the run's log;
    the page's path (None: --no-report or no log)."""
    samples = watch.sampler.stop()
    if not watch.enabled or run.log_dir is None:
        return None
    # the watch started before run_tests' own clock: its span is the run's wall time
    wall = time.monotonic() - watch.recorder.start
    timings = RunTimings(wall, cpu_times() - watch.cpu_before, cores,
                         tuple(watch.recorder.rows()))
    try:
        write_timings(run.log_dir, timings)
    except OSError as exc:
        return f"report not written: {exc.strerror or exc}"
    return _written(run.log_dir, test_report_data(plan, run, workers, cores, samples,
                                                 watch.sampler.origin))


def progress_of(plan: Selection, workers: int, *, durations: bool) -> Progress:
    """The status line's progress: the selected packages, their dependencies among them, and
    (`durations`) the build durations recorded last time, for the time left."""
    selected = set(plan.selected)
    dependencies = {n: plan.graph.direct(n) & selected for n in plan.selected}
    recorded = read_durations(plan.workspace.build_base) if durations else {}
    return Progress.of(dependencies, recorded, workers)


def test_dependencies(plan: Selection) -> dict[str, set[str]]:
    """What each selected package's tests wait for among the selected (testing/runners.py)."""
    from wsbuild.testing.runners import closure_under_test

    selected = set(plan.selected)
    return {n: closure_under_test(plan.graph, n) & selected for n in plan.selected}
