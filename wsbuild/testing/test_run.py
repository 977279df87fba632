"""`wsbuild test`: every selected package's tests, run against its install, results as JUnit XML.

The stages, in order:
1. verbs.load     discover → graph → selection (the packages to test)
2. check_built    the selected packages and everything on their test environment are installed
                  (closure.py)
3. session.py     the run's context, as a build's: lock, the ROS underlay's environment, the log
4. schedule       packages in dependency order and in parallel, in one run as a build's
                  (runreport/package_run.py: the scheduler's ready queue, the run's timings and
                  report); failing tests never stop the other packages (only --abort-on-error does)
5. per package    tester.py: its last passing result reused when nothing its tests observe
                  changed (test_key.py, cached_result.py; else its record is forgotten, and
                  written again on a pass); else the test runner its build type names
                  (`BuildType.test_runner`: pytest's, CTest's, a plugin's) runs in the
                  package's test environment (its install and its dependencies' applied as colcon
                  does, prefix/environment.py, and the pytest Jazzy's plugins accept,
                  pytest_env.py), repeated for --retest-until-fail / --retest-until-pass
6. results        the runner's JUnit files in <build>/<pkg>/test_results/<pkg>/ (or
                  <test-result-base>/<pkg>/) make each package's result and the summary
                  (results.py); log/<run>/timings.json, report.json and report.html, as a
                  build writes them
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild import inputs
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.errors import WorkspaceError
from wsbuild.events import Emit, Event, JobFinished, Notice
from wsbuild.prefix.layout import package_prefix, resolve_layout
from wsbuild.testing.closure import check_built, closure_under_test
from wsbuild.testing.results import (
    PackageStatus,
    PackageTests,
    TestRun,
    cached_text,
    problem_text,
)
from wsbuild.engine.ready_queue import JobGraph
from wsbuild.engine.timings import cpu_count, cpu_times
from wsbuild.engine.schedule import FailurePolicy, RunInterrupted
from wsbuild.testing.request import TestRequest
from wsbuild.testing.tester import PackageTester
from wsbuild.words import plural
from wsbuild.underlay.environment import prepare_underlay
from wsbuild.session import LINT_SHIM, SessionOptions, open_session
from wsbuild.runreport.report_json import RunFacts, path_in_log
from wsbuild.runreport.package_run import PackageRun
from wsbuild.observe.step_environment import step_base
from wsbuild.build_types.junit import read_junit

if TYPE_CHECKING:
    from wsbuild.record.dirty import Reason
    from wsbuild.workspace.selection import Selection


def jobs_under_test(selection: Selection) -> JobGraph:
    """The run's jobs: the selected packages, each waiting for the selected ones its tests run
    against (`closure_under_test`)."""
    selected = set(selection.selected)
    return JobGraph.of(selection.selected,
                       {n: closure_under_test(selection.graph, n) & selected for n in selection.selected})


def run_tests(selection: Selection, request: TestRequest, emit: Emit) -> TestRun:
    """Test the selected packages in one run as a build's (runreport/package_run.py: the same
    session, scheduler, timings and report). Test failures are results, not exceptions; a run
    cut short by Ctrl-C comes back with `interrupted` set."""
    started = time.monotonic()
    cpu_before = cpu_times()
    ws = selection.workspace
    merged = resolve_layout(ws.install_base, request.merge_install, verb="test")
    check_built(selection, merged)
    options = SessionOptions(verb="test", merge_install=request.merge_install,
                             wait_for_lock=request.wait_for_lock)
    with open_session(ws, options, emit) as session:
        assert session.run_log is not None
        jobs = jobs_under_test(selection)
        run = PackageRun(selection, session.run_log, jobs, report=request.report, started=started,
                         cpu_before=cpu_before)
        tester = PackageTester(selection, request, merged, session.environ, session.run_log,
                               observer=session.observer)
        reports: dict[str, PackageTests] = {}
        timed = run.timed(emit)  # a package's test steps enter the run's timings

        def job(name: str) -> JobResult:
            report = tester.test(name, timed)
            reports[name] = report
            return _shown(report)

        def show(event: Event) -> None:
            emit(event)
            if isinstance(event, JobFinished) and event.result.package in reports:
                report = reports[event.result.package]
                if report.status is PackageStatus.NO_TESTS:
                    emit(Notice(report.message or "no tests", package=report.package))
                elif report.cached:
                    emit(Notice(cached_text(report, Path.cwd()), package=report.package))

        policy = FailurePolicy.STOP if request.abort_on_error else FailurePolicy.CONTINUE
        interrupted = False
        try:
            results = run.run(jobs, job, workers=request.workers, policy=policy, emit=show)
        except RunInterrupted as interrupt:
            results, interrupted = interrupt.results, True
        final = tuple(_final(result, reports.get(result.package)) for result in results)
        facts = RunFacts(verb="test", cores=cpu_count(), workers=request.workers,
                         report=request.report)
        end = run.finish(results, facts, extra={
            r.package: _report_fields(r, session.run_log) for r in final})
        if isinstance(end.report, str):  # why the report was not written
            emit(Notice(end.report, warning=True))
    return TestRun(final, time.monotonic() - started, session.run_log, interrupted)


def _report_fields(report: PackageTests, run_log: Path) -> dict[str, object]:
    """A package's fields in the run's report.json: its status, counts and failing tests,
    each named with the JUnit file that holds it."""
    return {"outcome": report.status.value, "seconds": round(report.seconds, 3),
            "message": report.message, "reproduce": "",
            "log_dir": path_in_log(report.log_dir, run_log),
            "tests": {"tests": report.counts.tests, "failures": report.counts.failures,
                      "errors": report.counts.errors, "skipped": report.counts.skipped,
                      "flaky": report.flaky, "cached": report.cached,
                      "failing": _failing(report, run_log)}}


def _failing(report: PackageTests, run_log: Path) -> list[dict[str, str | None]]:
    """Each failing test's name, headline and the result file holding it."""
    holder: dict[tuple[str, str], Path] = {}
    for path in report.result_files:
        try:
            for case in read_junit(path).problems():
                holder.setdefault((case.classname, case.name), path)
        except (OSError, ValueError):
            continue
    return [{"name": case.full_name, "headline": case.headline,
             "junit": path_in_log(holder.get((case.classname, case.name)), run_log)}
            for case in report.problems]


def reusable_results(selection: Selection, request: TestRequest) -> set[str]:
    """The selected packages whose last passing result `run_tests` would reuse now (what
    colcon-cache's selection options call a valid test cache). Takes no lock, writes nothing."""
    return {name for name, reason in test_plan(selection, request) if reason is None}


def test_plan(selection: Selection, request: TestRequest) -> list[tuple[str, Reason | None]]:
    """Each selected package with tests, and why its tests would run (record/tested.py's
    `Reason`; None: its last passing result is reused), as `run_tests` decides it now
    (`wsbuild test --dry-run`). Takes no lock, writes nothing."""
    ws = selection.workspace
    try:
        merged = resolve_layout(ws.install_base, request.merge_install, verb="test")
    except WorkspaceError:
        return []
    underlay = prepare_underlay(os.environ, executable=sys.executable, repair=False,
                                shim_dir=ws.build_base / LINT_SHIM, notice=lambda _text: None,
                                dry_run=True)
    tester = PackageTester(selection, request, merged, step_base(underlay.environ), ws.log_base)
    plan: list[tuple[str, Reason | None]] = []
    for name in selection.selected:
        runner = tester.runner(name)
        if runner is None:
            continue
        for dep in (name, *closure_under_test(selection.graph, name)):
            # what environment_for reads of each prefix (package.dsv, its hooks): declared,
            # as every read of a run that only plans (wsbuild/inputs.py)
            share = package_prefix(ws.install_base, dep, merged=merged) / "share" / dep
            for path in inputs.walk_files(share):
                inputs.declare_file(path)
        ctx = tester.context(name, runner, None)
        plan.append((name, tester.decided(name, tester.key(runner, ctx), ctx.environ)[1]))
    return plan


def test_plan_lines(plan: list[tuple[str, Reason | None]]) -> list[str]:
    """`wsbuild test --dry-run`: each package's decision, as `build --dry-run` words a
    build's (`test: <why>`, from the same `Reason`)."""
    running = [name for name, reason in plan if reason is not None]
    lines = [f"dry run: {plural(len(plan), 'package')} with tests, {len(running)} would run "
             f"their tests, {len(plan) - len(running)} reuse their last passing result "
             "(nothing was touched)"]
    width = max((len(name) for name, _ in plan), default=0)
    digits = len(str(len(plan)))
    for number, (name, reason) in enumerate(plan, start=1):
        what = f"test: {reason.text}" if reason is not None else \
            "reuse the last passing result: nothing its tests read changed"
        lines.append(f"  {number:>{digits}}. {name.ljust(width)}  {what}")
    return lines


def _shown(report: PackageTests) -> JobResult:
    """How the reporter shows a package: failing tests as a failed package, with its log."""
    if report.status is PackageStatus.FAILED:
        return JobResult(report.package, Outcome.FAILED, report.seconds,
                           message=problem_text(report.counts) or report.message,
                           log_dir=report.log_dir)
    if report.status is PackageStatus.INTERRUPTED:
        return JobResult(report.package, Outcome.INTERRUPTED, report.seconds)
    if report.cached:  # drawn by its notice (cached_text), as an up-to-date build is by none
        return JobResult(report.package, Outcome.UP_TO_DATE, report.seconds)
    return JobResult(report.package, Outcome.FINISHED, report.seconds, log_dir=report.log_dir)


def _final(result: JobResult, report: PackageTests | None) -> PackageTests:
    if report is not None:
        return report
    status = {Outcome.SKIPPED: PackageStatus.NOT_RUN,
              Outcome.INTERRUPTED: PackageStatus.INTERRUPTED}.get(result.outcome,
                                                                  PackageStatus.FAILED)
    return PackageTests(result.package, status, message=result.message, seconds=result.seconds)
