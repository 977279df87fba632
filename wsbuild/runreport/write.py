"""The report's files of a run: a CPU sampler started with the run, and at its end
`report.json` then `report.html` in the run's log directory (runreport/package_run.py calls
them for build and test alike); the status line's progress."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.engine.cpu_sampler import CpuSampler
from wsbuild.engine.jobs import JobResult
from wsbuild.engine.progress import Progress
from wsbuild.engine.ready_queue import JobGraph
from wsbuild.engine.timings import read_durations
from wsbuild.runreport.report_json import RunFacts, report_data, write_report_json

if TYPE_CHECKING:
    from wsbuild.workspace.selection import Selection


def start_sampler(enabled: bool, origin: float) -> CpuSampler:
    """The run's CPU sampler (times since `origin`, the run's timing origin); one that records
    nothing when the report is off."""
    return CpuSampler.started(origin=origin) if enabled else CpuSampler(origin=origin)


def write_run_report(selection: Selection, facts: RunFacts, run_log: Path, jobs: JobGraph,
                     results: Sequence[JobResult], sampler: CpuSampler, *, page: bool,
                     extra: Mapping[str, Mapping[str, object]] | None = None
                     ) -> Path | str | None:
    """report.json then (`page`) report.html; the page's path (None: not drawn), or why it
    was not written."""
    samples = sampler.stop()
    try:
        write_report_json(run_log, report_data(selection, facts, run_log, jobs, results, samples,
                                         sampler.origin, extra))
        if not page:
            return None
        from wsbuild.runreport.page import write_report  # lazy: off the full no-op build

        return write_report(run_log)
    except OSError as exc:
        return f"report not written: {exc.strerror or exc}"


def progress_of(selection: Selection, workers: int, *, durations: bool) -> Progress:
    """The status line's progress: the selected packages, their dependencies among them, and
    (`durations`) the build durations recorded last time, for the time left."""
    selected = set(selection.selected)
    dependencies = {n: selection.graph.direct(n) & selected for n in selection.selected}
    recorded = read_durations(selection.workspace.build_base) if durations else {}
    return Progress.of(dependencies, recorded, workers)
