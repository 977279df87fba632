"""`wsbuild test`: every selected package's tests, run against its install, results as JUnit XML.

The stages, in order:
1. verbs.load     discover → graph → selection (the packages to test)
2. check_built    the selected packages and everything on their test environment are installed
                  (closure.py)
3. session.py     the run's context, as a build's: lock, the ROS underlay's environment, the log
4. schedule       packages in dependency order and in parallel (engine/schedule.py);
                  failing tests never stop the other packages (only --abort-on-error does)
5. per package    tester.py: its last passing result reused when nothing its tests observe
                  changed (test_key.py, cached_result.py; else its record is forgotten, and
                  written again on a pass); else the test runner its build type names
                  (`BuildType.test_runner`: pytest's, CTest's, a plugin's) runs in the
                  package's test environment (its install and its dependencies' applied as colcon
                  does, prefix/environment.py, and the pytest Jazzy's plugins accept,
                  pytest_env.py), repeated for --retest-until-fail / --retest-until-pass
6. results        the runner's JUnit files in <build>/<pkg>/test_results/<pkg>/ (or
                  <test-result-base>/<pkg>/) make each package's result and the summary
                  (results.py)
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild import inputs
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.errors import WorkspaceError
from wsbuild.events import Emit, Event, JobFinished, Notice
from wsbuild.prefix.layout import package_prefix
from wsbuild.testing.closure import check_built, closure_under_test
from wsbuild.testing.results import (
    PackageStatus,
    PackageTests,
    TestRun,
    cached_text,
    problem_text,
)
from wsbuild.testing.tester import PackageTester

if TYPE_CHECKING:
    from wsbuild.workspace.selected import Selection

#: check_built and closure_under_test are closure.py's; runreport/ still imports the latter from
#: here (its module is another engineer's while issue 30 is worked on)
__all__ = ["TestRequest", "check_built", "closure_under_test", "reusable_results", "run_tests"]


@dataclass(frozen=True, slots=True)
class TestRequest:
    """The options of `wsbuild test` that shape the run."""

    __test__ = False  # not a pytest test class

    #: a test tool's name ("pytest", "ctest", a plugin runner's) → the command line's
    #: arguments for it (--pytest-args, --ctest-args)
    tool_arguments: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    #: package name → tool name → the arguments its colcon.meta adds (after the command line's,
    #: as colcon extends lists with meta values)
    package_arguments: Mapping[str, Mapping[str, tuple[str, ...]]] = field(default_factory=dict)
    retest_until_fail: int = 0
    retest_until_pass: int = 0
    #: results go to <test_result_base>/<pkg>/ instead of <build>/<pkg>/test_results/<pkg>/
    test_result_base: Path | None = None
    #: None: whatever install/ holds (its layout marker)
    merge_install: bool | None = None
    workers: int = 1
    abort_on_error: bool = False
    wait_for_lock: bool = True
    python_executable: str = sys.executable
    #: a test module importing an ament linter that is not installed is an error, not a skip
    strict_linters: bool = False
    #: reuse a package's last passing result while nothing its tests observe changed
    #: (cached_result.py); False: --no-test-cache
    reuse_results: bool = True

    @property
    def max_attempts(self) -> int:
        return 1 + max(self.retest_until_fail, self.retest_until_pass)


def run_tests(plan: Selection, request: TestRequest, emit: Emit) -> TestRun:
    """Test the selected packages. Test failures are results, not exceptions; a run cut short
    by Ctrl-C comes back with `interrupted` set."""
    from wsbuild.engine.schedule import FailurePolicy, RunInterrupted, run_jobs
    from wsbuild.prefix.layout import resolve_layout
    from wsbuild.session import SessionOptions, open_session

    ws = plan.workspace
    merged = resolve_layout(ws.install_base, request.merge_install, verb="test")
    check_built(plan, merged)
    started = time.monotonic()
    options = SessionOptions(verb="test", merge_install=request.merge_install,
                             wait_for_lock=request.wait_for_lock)
    with open_session(ws, options, emit) as session:
        assert session.run_log is not None
        tester = PackageTester(plan, request, merged, session.environ, session.run_log)
        reports: dict[str, PackageTests] = {}

        def job(name: str) -> JobResult:
            report = tester.test(name, emit)
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

        selected = set(plan.selected)
        dependencies = {n: closure_under_test(plan.graph, n) & selected for n in plan.selected}
        policy = FailurePolicy.STOP if request.abort_on_error else FailurePolicy.CONTINUE
        interrupted = False
        try:
            results = run_jobs(plan.selected, dependencies, job, workers=request.workers,
                               policy=policy, emit=show)
        except RunInterrupted as interrupt:
            results, interrupted = interrupt.results, True
    final = tuple(_final(result, reports.get(result.package)) for result in results)
    return TestRun(final, time.monotonic() - started, session.run_log, interrupted)


def reusable_results(plan: Selection, request: TestRequest) -> set[str]:
    """The selected packages whose last passing result `run_tests` would reuse now (what
    colcon-cache's selection options call a valid test cache). Takes no lock, writes nothing."""
    from wsbuild.prefix.layout import resolve_layout
    from wsbuild.session import LINT_SHIM
    from wsbuild.underlay.environment import prepare_underlay

    ws = plan.workspace
    try:
        merged = resolve_layout(ws.install_base, request.merge_install, verb="test")
    except WorkspaceError:
        return set()
    underlay = prepare_underlay(os.environ, executable=sys.executable, repair=False,
                                shim_dir=ws.build_base / LINT_SHIM, notice=lambda _text: None,
                                dry_run=True)
    tester = PackageTester(plan, request, merged, underlay.environ, ws.log_base)
    valid = set()
    for name in plan.selected:
        runner = tester.runner(name)
        if runner is None:
            continue
        for dep in (name, *closure_under_test(plan.graph, name)):
            # what environment_for reads of each prefix (package.dsv, its hooks): declared,
            # as every read of a run that only plans (wsbuild/inputs.py)
            share = package_prefix(ws.install_base, dep, merged=merged) / "share" / dep
            for path in inputs.walk_files(share):
                inputs.declare_file(path)
        ctx = tester.context(name, runner, None)
        if tester.reusable(name, tester.key(runner, ctx), None) is not None:
            valid.add(name)
    return valid


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
