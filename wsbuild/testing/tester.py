"""One package's tests, run by its build type's test runner: in its test environment,
observed as a build's steps are (observe/), its last passing result reused while nothing its
tests read changed, repeated for --retest-until-fail / --retest-until-pass, and turned into
the package's result."""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.build_types import Command, get_build_type
from wsbuild.build_types.junit import BadResultFile, Case, CaseOutcome, Counts, NotJUnit
from wsbuild.build_types.junit import ResultFile, read_junit
from wsbuild.build_types.test_runner import TestContext, TestOutcome, TestRunner
from wsbuild.engine.process import REGISTRY, Completed, env_delta, format_command, run_command
from wsbuild.observe.steps import OBSERVE_TEST_DIR, StepObservations
from wsbuild.events import Emit, StepStarted
from wsbuild.prefix.layout import package_prefix
from wsbuild.prefix import environment_for
from wsbuild.testing.cached_result import (
    CachedResult,
    file_stamps,
    forget_cached_result,
    read_cached_result,
    write_cached_result,
)
from wsbuild.testing.closure import closure_under_test
from wsbuild.testing.linters import MISSING_LINTER_PREFIX
from wsbuild.testing.results import PackageStatus, PackageTests, results_dir
from wsbuild.testing.test_key import TestKeys
from wsbuild.testing.tooling import tooling_failures
from wsbuild.underlay.lint_programs import missing_program
from wsbuild.engine.logs import append_command_log

from wsbuild.record.tested import TestKey, rerun_reason
from wsbuild.record.outside import Digests
from wsbuild.record.environment import variable_digests

if TYPE_CHECKING:
    from wsbuild.observe.library import Observer
    from wsbuild.record.dirty import Reason
    from wsbuild.record.outside import OutsideReads
    from wsbuild.testing.request import TestRequest
    from wsbuild.workspace.selection import Selection


@dataclass(slots=True)
class PackageTester:
    """Runs one package's tests; shared by the worker threads (holds no per-package state)."""

    selection: Selection
    request: TestRequest
    merged: bool
    base_env: Mapping[str, str]
    run_log: Path
    #: the step observer (or why there is none); None: a run that only plans
    observer: Observer | str | None = None
    order: list[str] = field(default_factory=list)
    keys: TestKeys | None = None

    def __post_init__(self) -> None:
        self.order = self.selection.graph.topological_order()
        self.keys = TestKeys(self.selection, self.request, self.merged)

    def runner(self, name: str) -> TestRunner | None:
        return get_build_type(self.selection.packages[name].build_type).test_runner

    def context(self, name: str, runner: TestRunner, log_dir: Path | None,
                observations: StepObservations | None = None,
                stopped: list[str] | None = None) -> TestContext:
        """What the package's runner works with; without a log directory it may run nothing
        (the key of a run that only plans). Each command it runs is observed into
        `observations`; what its commands left running is stopped when each ends, and named
        in `stopped`."""
        env = runner.environment(self.environment(name), self.request.python_executable)
        arguments = (*self.request.tool_arguments.get(runner.name, ()),
                     *self.request.package_arguments.get(name, {}).get(runner.name, ()))

        def run(command: Command, *, on_line: Callable[[str, bool], None] | None = None,
                logged: bool = True) -> Completed:
            if log_dir is None:
                raise RuntimeError(f"{name}: a run that only plans runs no test command")
            completed = _run(command, env, log_dir, on_line, logged, observations, runner.name)
            if completed.stopped:
                _log(log_dir, f"Stopped what {command.argv[0]} left running: "
                              f"{', '.join(completed.stopped)}")
                if stopped is not None:
                    stopped.extend(completed.stopped)
            return completed

        return TestContext(
            package=self.selection.packages[name], build_dir=self.selection.workspace.build_base / name,
            results_dir=results_dir(self.selection.workspace, name, self.request.test_result_base),
            environ=env, arguments=arguments, python_executable=self.request.python_executable,
            strict_linters=self.request.strict_linters, run=run)

    def key(self, runner: TestRunner, ctx: TestContext) -> TestKey | None:
        assert self.keys is not None
        return self.keys.key(runner, ctx)

    def reusable(self, name: str, key: TestKey | None, log_dir: Path | None,
                 environ: Mapping[str, str] | None = None) -> CachedResult | None:
        """The package's last passing result, when it still holds (`environ`: the
        environment its tests would run in now); why not, in its log."""
        cached, reason = self.decided(name, key, environ)
        if reason is None:
            return cached
        if log_dir is not None:
            _log(log_dir, f"test result not reused: {reason.text}")
        return None

    def decided(self, name: str, key: TestKey | None, environ: Mapping[str, str] | None
                ) -> tuple[CachedResult | None, Reason | None]:
        """The package's last passing result, and why its tests run again rather than reuse
        it (record/tested.py; None: it holds)."""
        cached = read_cached_result(self.selection.workspace.build_base / name) \
            if key is not None and self.request.reuse_results else None
        return cached, rerun_reason(
            key, cached.run() if cached is not None else None, environ=environ,
            own_install=str(self.selection.workspace.install_base),
            ignored=self.request.env_ignore, forced=not self.request.reuse_results)

    def environment(self, name: str) -> dict[str, str]:
        """The package's install last, after its test closure in dependency order."""
        closure = closure_under_test(self.selection.graph, name)
        install_base = self.selection.workspace.install_base
        prefixes = [(package_prefix(install_base, dep, merged=self.merged), dep)
                    for dep in self.order if dep in closure]
        prefixes.append((package_prefix(install_base, name, merged=self.merged), name))
        return environment_for(prefixes, self.base_env)

    def test(self, name: str, emit: Emit) -> PackageTests:
        started = time.monotonic()
        package = self.selection.packages[name]
        log_dir = self.run_log / name
        log_dir.mkdir(parents=True, exist_ok=True)
        runner = self.runner(name)
        if runner is None:
            return PackageTests(name, PackageStatus.NO_TESTS, log_dir=log_dir,
                                message=f"wsbuild cannot test '{package.build_type}' packages")
        build_dir = self.selection.workspace.build_base / name
        observations = StepObservations(build_dir / OBSERVE_TEST_DIR,
                                        self.observer or "this run observes nothing")
        stopped: list[str] = []
        ctx = self.context(name, runner, log_dir, observations, stopped)
        key = self.key(runner, ctx)
        cached = self.reusable(name, key, log_dir, ctx.environ)
        if cached is not None:
            _log(log_dir, f"test result reused from {cached.log_dir}: nothing its tests "
                          "observe changed")
            files = tuple(Path(p) for p in cached.result_files)
            return PackageTests(name, PackageStatus.PASSED, cached.counts,
                                result_files=files, log_dir=cached.log_dir, cached=True,
                                seconds=time.monotonic() - started,
                                missing_linters=_missing_linters_in(files))
        forget_cached_result(ctx.build_dir)
        ctx.results_dir.mkdir(parents=True, exist_ok=True)
        observations.start()
        report = self._attempts(runner, ctx, log_dir, emit)
        report = replace(report, log_dir=log_dir, seconds=time.monotonic() - started,
                         stopped=tuple(stopped))
        if key is not None and _reusable_later(report):
            reads, environment, unobserved = self._observed(name, ctx, observations, log_dir,
                                                            started)
            write_cached_result(ctx.build_dir, CachedResult(
                key, report.counts, file_stamps(report.result_files), log_dir, report.seconds,
                reads, environment, unobserved))
        return report

    def _observed(self, name: str, ctx: TestContext, observations: StepObservations,
                  log_dir: Path, started: float
                  ) -> tuple[OutsideReads, dict[str, str], tuple[str, ...]]:
        """What the test run read outside the package (its own results and logs, the
        package's build directory and its install, which its keys hold, left out), and the
        variables it read, by their values in the package's test environment (what the
        runner's command sets on top of it derives from the test options, in the key)."""
        from wsbuild.record.observed import Where, observed_reads  # lazy: off `test`

        ws = self.selection.workspace
        prefix = package_prefix(ws.install_base, name, merged=self.merged)
        outputs = (str(ctx.results_dir), str(log_dir), str(ctx.build_dir),
                   *(() if self.merged else (str(prefix),)))
        reads = observed_reads(observations, Where(str(ctx.package.path.absolute()), outputs),
                               Digests(), started_ns=int(time.time_ns()
                                                         - (time.monotonic() - started) * 1e9))
        environment = variable_digests(ctx.environ, reads.seen, own_install=str(ws.install_base),
                                       ignored=self.request.env_ignore)
        return reads.outside, environment, reads.observation.unobserved

    def _attempts(self, runner: TestRunner, ctx: TestContext, log_dir: Path,
                  emit: Emit) -> PackageTests:
        """The runner's run, repeated as --retest-until-fail / --retest-until-pass ask."""
        attempts = self.request.max_attempts
        attempt = 0
        while True:
            attempt += 1
            if attempts > 1:
                _log(log_dir, f"--- attempt {attempt} of {attempts} ---")
            label = runner.name if attempt == 1 else f"{runner.name} {attempt}/{attempts}"
            emit(StepStarted(ctx.name, label))
            report = package_result(ctx.name, runner.run(ctx), self.request.python_executable,
                                    getattr(runner, "tool_cases", frozenset()),
                                    require_linters=self.request.strict_linters)
            if REGISTRY.cancelled.is_set():
                report = replace(report, status=PackageStatus.INTERRUPTED)
                break
            if report.status is PackageStatus.NO_TESTS or attempt >= attempts:
                break
            again = (PackageStatus.FAILED if self.request.retest_until_pass
                     else PackageStatus.PASSED)
            if report.status is not again:
                break
        flaky = attempt > 1 and report.status is (
            PackageStatus.PASSED if self.request.retest_until_pass else PackageStatus.FAILED)
        return replace(report, attempts=attempt, max_attempts=attempts, flaky=flaky)


def package_result(name: str, outcome: TestOutcome, python_executable: str,
                   tool_cases: frozenset[str] = frozenset(), *,
                   require_linters: bool = False) -> PackageTests:
    """A package's result from what its runner found: failed when any test failed or erred;
    the tests skipped for a missing linter and the tooling failures named (`tool_cases`: the
    cases its runner writes when its tool failed). A linter test whose program is not
    installed (cppcheck) is not run, as a linter that is not installed: counted as skipped
    and named with what installs it, unless `require_linters` (then it fails the run)."""
    files: Sequence[ResultFile] = outcome.files
    counts = Counts.total(result.counts for result in files)
    if outcome.no_tests:
        return PackageTests(name, PackageStatus.NO_TESTS, counts,
                            result_files=tuple(result.path for result in files),
                            message=outcome.no_tests)
    problems: list[Case] = []
    for result in files:
        problems += result.problems()
    unrun: list[tuple[str, str]] = []
    if not require_linters:
        for case in [c for c in problems if c.outcome is CaseOutcome.ERROR]:
            program = missing_program(f"{case.message}\n{case.details}")
            if program is not None:
                problems.remove(case)
                # CTest's test is the case's first name (`cppcheck.xunit.missing_result`)
                test = case.name.split(".")[0] or case.name
                unrun.append((test, f"{program.name}: {program.install_command()}"))
        counts = replace(counts, errors=counts.errors - len(unrun),
                         skipped=counts.skipped + len(unrun))
    status = PackageStatus.FAILED if counts.failed else PackageStatus.PASSED
    return PackageTests(name, status, counts, tuple(problems),
                        tuple(result.path for result in files),
                        missing_linters=_missing_linters(files),
                        tooling=tooling_failures(problems, python_executable, tool_cases),
                        missing_programs=tuple(unrun))


def _missing_linters(files: Sequence[ResultFile]) -> tuple[str, ...]:
    """The linters whose tests were skipped as not installed (the skip reason names them)."""
    return tuple(sorted({c.message[len(MISSING_LINTER_PREFIX):].strip()
                         for result in files for c in result.cases
                         if c.outcome is CaseOutcome.SKIPPED
                         and c.message.startswith(MISSING_LINTER_PREFIX)}))


def _missing_linters_in(paths: Sequence[Path]) -> tuple[str, ...]:
    """`_missing_linters` of a reused result's JUnit files (unchanged since, as its reuse
    checked), so its summary still names them."""
    try:
        return _missing_linters([read_junit(path) for path in paths])
    except (NotJUnit, BadResultFile):
        return ()


def _run(command: Command, env: Mapping[str, str], log_dir: Path,
         on_line: Callable[[str, bool], None] | None, logged: bool,
         observations: StepObservations | None, label: str) -> Completed:
    """A runner's command, in the package's test environment plus the command's own variables,
    observed into `observations` as step `label`; its line logged as one that reproduces it
    by hand."""
    shown = {**env, **command.env}
    delta = env_delta(shown, os.environ)
    _log(log_dir, f"Invoking command in '{command.cwd}': "
                  f"{format_command(command.argv, command.cwd, delta)}")
    full = {**shown, **command.run_env}
    if observations is None:
        return run_command(command.argv, cwd=command.cwd, env=full,
                           log_dir=log_dir if logged else None, on_line=on_line, sweep=True)
    token, observed = observations.begin(label, full, run_only=tuple(command.run_env))
    try:
        return run_command(command.argv, cwd=command.cwd, env=observed,
                           log_dir=log_dir if logged else None, on_line=on_line, sweep=True)
    finally:
        observations.finish(token)


def _reusable_later(report: PackageTests) -> bool:
    """Only a plain pass is kept: not one that needed a retry (flaky), nor one where the
    tooling failed. One whose tests were skipped because their linter is not installed is a
    pass like another: which tools are installed is part of its key, so installing the linter
    runs them again."""
    return (report.status is PackageStatus.PASSED and not report.flaky
            and not report.tooling and not report.missing_programs
            and not REGISTRY.cancelled.is_set())


def _log(log_dir: Path, line: str) -> None:
    append_command_log(log_dir, line)
