"""`wsbuild test`: every selected package's tests, run against its install, results as JUnit XML.

The stages, in order:
1. verbs.load     discover → graph → selection (the packages to test)
2. check_built    the selected packages and everything on their test environment are installed
3. session.py     the run's context, as a build's: lock, the ROS underlay's environment, the log
4. schedule       packages in dependency order and in parallel (engine/schedule.py); failing tests never
                  stop the other packages (only --abort-on-error does)
5. per package    its last passing result reused when nothing its tests observe changed
                  (cached_result.py; else its record is forgotten, and written again on a pass);
                  the tool its build type names (build_types' `test_tool`): `python -m pytest`
                  in the source directory, or `ctest` in the build directory; both with the
                  package's own install and its dependencies' applied as colcon does
                  (prefix/environment.py) and the pytest Jazzy's plugins accept (pytest_env.py),
                  repeated for --retest-until-fail / --retest-until-pass; a test module whose
                  ament linter is not installed is skipped as such (missing_linters.py)
6. results        JUnit XML in <build>/<pkg>/test_results/<pkg>/ (or <test-result-base>/<pkg>/),
                  read back through testing/junit.py into each package's result and the summary

What a run found and its summary are results.py's. Over 500 lines because the stages above
share one run state (`_Tester`): pytest's and CTest's runs read the same request,
environment, result directories and cached results.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import signal
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.build_types import TestTool, get_build_type
from wsbuild.engine.process import (
    REGISTRY,
    Completed,
    env_delta,
    format_command,
    run_command,
)
from wsbuild.errors import WorkspaceError
from wsbuild.prefix.layout import is_installed, package_prefix
from wsbuild.events import Emit, Event, JobFinished, Notice, StepStarted
from wsbuild import __version__, inputs
from wsbuild.testing.cached_result import (
    CachedResult,
    TestKey,
    BuildRecord,
    file_stamps,
    forget_cached_result,
    interpreter_tools,
    observed_environment,
    read_build_record,
    read_cached_result,
    source_signature,
    stat_signature,
    write_cached_result,
)
from wsbuild.testing.pytest_env import ros_pytest_dir, with_ros_pytest
from wsbuild.testing.linters import MISSING_LINTER_PREFIX
from wsbuild.testing.results import (
    PackageStatus,
    PackageTests,
    TestRun,
    cached_text,
    problem_text,
)
from wsbuild.testing.tooling import tooling_failures
from wsbuild.testing.junit import (
    BadResultFile,
    Case,
    CaseOutcome,
    Counts,
    NotJUnit,
    ResultFile,
    ament_result_file,
    read_ctest_junit,
    read_junit,
    write_junit,
)
from wsbuild.workspace.graph import Graph
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.workspace.model import DepCategory
from wsbuild.workspace.root import Workspace


if TYPE_CHECKING:
    from wsbuild.workspace.selected import Selection

#: pytest's exit code when it collected no tests
PYTEST_NO_TESTS = 5
#: CTest's exit code when some tests failed (anything else non-zero is CTest itself failing)
CTEST_TESTS_FAILED = 8


@dataclass(frozen=True, slots=True)
class TestRequest:
    """The options of `wsbuild test` that shape the run."""

    __test__ = False  # not a pytest test class

    #: a test tool's name ("pytest", "ctest") → the command line's arguments for it
    tool_arguments: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    #: package name → tool name → the arguments its colcon.meta adds (after the command line's)
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

    def arguments(self, tool: str, package: str) -> tuple[str, ...]:
        """What `tool` gets for `package`: the command line's, then its colcon.meta's."""
        return (*self.tool_arguments.get(tool, ()),
                *self.package_arguments.get(package, {}).get(tool, ()))


# ------------------------------------------------------------------------------ planning


def closure_under_test(graph: Graph, name: str) -> set[str]:
    """What a package's tests run against besides itself: its direct dependencies of every
    category and, recursively, their run dependencies (colcon test's recursive_categories=run)."""
    result: set[str] = set()
    stack = list(graph.direct(name))
    while stack:
        dep = stack.pop()
        if dep not in result and dep != name:
            result.add(dep)
            stack.extend(graph.direct(dep, (DepCategory.RUN,)))
    return result


def results_dir(workspace: Workspace, name: str, test_result_base: Path | None) -> Path:
    """Where a package's JUnit files go: beside ament_cmake's, or under --test-result-base."""
    if test_result_base is not None:
        return test_result_base / name
    return workspace.build_base / name / "test_results" / name


def check_built(plan: Selection, merged: bool) -> None:
    """Refuse to test packages that are not built, or whose test environment is not: all at once."""
    missing: dict[str, set[str]] = {}
    install_base = plan.workspace.install_base
    for name in plan.selected:
        for dep in sorted({name} | closure_under_test(plan.graph, name)):
            if not is_installed(install_base, dep, merged=merged):
                missing.setdefault(dep, set()).add(name)
        tool = get_build_type(plan.packages[name].build_type).test_tool
        needs_build_dir = tool is not None and tool.needs_build_dir
        if needs_build_dir and not (plan.workspace.build_base / name / "CMakeCache.txt").is_file():
            missing.setdefault(name, set()).add(name)
    if not missing:
        return
    items = "; ".join(
        dep if users == {dep} else f"{dep} (needed to test {', '.join(sorted(users - {dep}))})"
        for dep, users in sorted(missing.items()))
    raise WorkspaceError(
        f"not built: {items}",
        hint=f"build first: wsbuild build --packages-up-to {' '.join(sorted(missing))}",
    )


# ------------------------------------------------------------------------------- running


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
        tester = _Tester(plan, request, merged, session.environ, session.run_log)
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
    tester = _Tester(plan, request, merged, underlay.environ, ws.log_base)
    valid = set()
    for name in plan.selected:
        test_tool = get_build_type(plan.packages[name].build_type).test_tool
        if test_tool is None:
            continue
        for dep in (name, *closure_under_test(plan.graph, name)):
            # what environment_for reads of each prefix (package.dsv, its hooks): declared,
            # as every read of a run that only plans (wsbuild/inputs.py)
            share = package_prefix(ws.install_base, dep, merged=merged) / "share" / dep
            for path in inputs.walk_files(share):
                inputs.declare_file(path)
        env = with_ros_pytest(tester.environment(name), request.python_executable)
        if tester.reusable(name, tester.test_key(name, test_tool, env), None) is not None:
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


@dataclass(slots=True)
class _Tester:
    """Runs one package's tests; shared by the worker threads (holds no per-package state)."""

    plan: Selection
    request: TestRequest
    merged: bool
    base_env: Mapping[str, str]
    run_log: Path
    order: list[str] = field(default_factory=list)
    #: memos shared by the packages' keys: each package's build record and source signature,
    #: the interpreter's tools
    _builds: dict[str, BuildRecord | None] = field(default_factory=dict)
    _sources: dict[str, str] = field(default_factory=dict)
    _tools: str = ""

    def __post_init__(self) -> None:
        self.order = self.plan.graph.topological_order()
        self._tools = interpreter_tools(self.request.python_executable,
                                        ros_pytest_dir(self.request.python_executable))

    def _build(self, name: str) -> BuildRecord | None:
        if name not in self._builds:
            self._builds[name] = read_build_record(self.plan.workspace.build_base / name)
        return self._builds[name]

    def _installed_output(self, name: str) -> str | None:
        """What stands in for a package's installed output: its build key, and with a
        symlink install also its sources (which the install links to)."""
        build = self._build(name)
        if build is None:
            return None
        if not build.symlink_install:
            return build.key
        if name not in self._sources:
            self._sources[name] = source_signature(self.plan.packages[name].path)
        return f"{build.key}+{self._sources[name]}"

    def test_key(self, name: str, tool: TestTool, env: Mapping[str, str]) -> TestKey | None:
        """What the package's tests can observe (cached_result.py); None when a package of
        its test closure was not built by wsbuild (no build key to compare)."""
        own = self._build(name)
        closure = {dep: self._installed_output(dep) for dep in
                   closure_under_test(self.plan.graph, name) if dep in self.plan.packages}
        if own is None or None in closure.values():
            return None
        build_dir = self.plan.workspace.build_base / name
        request = self.request
        tools = [self._tools]
        extra: list[Path] = []
        if tool is TestTool.CTEST:
            ctest = inputs.which("ctest", path=env.get("PATH"))
            tools.append(f"{ctest}:{stat_signature(ctest) if ctest else ''}")
            extra = [build_dir / "CTestTestfile.cmake", build_dir / ".ninja_log"]
        # each tool's own arguments only: --pytest-args leave CTest's results valid
        passed = request.arguments(tool.value, name)
        options = [__version__, tool.value, list(passed),
                   request.retest_until_fail, request.retest_until_pass, request.strict_linters,
                   str(results_dir(self.plan.workspace, name, request.test_result_base)),
                   self.merged, request.python_executable]
        return TestKey(
            build=own.key, closure={dep: key for dep, key in closure.items() if key is not None},
            sources=source_signature(self.plan.packages[name].path, extra),
            options=json.dumps(options), environment=observed_environment(env),
            tools=json.dumps(tools))

    def reusable(self, name: str, key: TestKey | None, log_dir: Path | None) -> CachedResult | None:
        """The package's last passing result, when it applies to `key`; why not, in its log."""
        if key is None:
            why = "not built by wsbuild (no build key), nor all of its test closure"
        else:
            cached = read_cached_result(self.plan.workspace.build_base / name)
            if cached is None:
                why = "no passing result recorded"
            elif cached.key != key:
                why = key.changed_since(cached.key) or "its key changed"
            elif not cached.files_unchanged():
                why = "its result files changed or are gone"
            else:
                return cached
        if log_dir is not None:
            _log(log_dir, f"test result not reused: {why}")
        return None

    def environment(self, name: str) -> dict[str, str]:
        """The package's install last, after its test closure in dependency order."""
        from wsbuild.prefix import environment_for

        closure = closure_under_test(self.plan.graph, name)
        install_base = self.plan.workspace.install_base
        prefixes = [(package_prefix(install_base, dep, merged=self.merged), dep)
                    for dep in self.order if dep in closure]
        prefixes.append((package_prefix(install_base, name, merged=self.merged), name))
        return environment_for(prefixes, self.base_env)

    def test(self, name: str, emit: Emit) -> PackageTests:
        started = time.monotonic()
        package = self.plan.packages[name]
        log_dir = self.run_log / name
        log_dir.mkdir(parents=True, exist_ok=True)
        test_tool = get_build_type(package.build_type).test_tool
        if test_tool is TestTool.PYTEST:
            tool, run_once = "pytest", self._pytest
        elif test_tool is TestTool.CTEST:
            tool, run_once = "ctest", self._ctest
        else:
            return PackageTests(name, PackageStatus.NO_TESTS, log_dir=log_dir,
                                message=f"wsbuild cannot test '{package.build_type}' packages")
        env = with_ros_pytest(self.environment(name), self.request.python_executable)
        build_dir = self.plan.workspace.build_base / name
        key = self.test_key(name, test_tool, env)
        if self.request.reuse_results:
            cached = self.reusable(name, key, log_dir)
            if cached is not None:
                _log(log_dir, f"test result reused from {cached.log_dir}: nothing its tests "
                              "observe changed")
                return PackageTests(name, PackageStatus.PASSED, cached.counts,
                                    result_files=tuple(Path(p) for p in cached.result_files),
                                    log_dir=cached.log_dir, cached=True,
                                    seconds=time.monotonic() - started)
        forget_cached_result(build_dir)
        target = results_dir(self.plan.workspace, name, self.request.test_result_base)
        target.mkdir(parents=True, exist_ok=True)
        attempts = self.request.max_attempts
        attempt = 0
        while True:
            attempt += 1
            if attempts > 1:
                _log(log_dir, f"--- attempt {attempt} of {attempts} ---")
            emit(StepStarted(name, tool if attempt == 1 else f"{tool} {attempt}/{attempts}"))
            report = run_once(name, env, target, log_dir)
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
        report = replace(report, log_dir=log_dir, attempts=attempt, max_attempts=attempts,
                         flaky=flaky, seconds=time.monotonic() - started)
        if key is not None and _reusable_later(report):
            write_cached_result(build_dir, CachedResult(
                key, report.counts, file_stamps(report.result_files), log_dir, report.seconds))
        return report

    def _run(self, command: Sequence[str], *, cwd: Path, env: Mapping[str, str], log_dir: Path,
             on_line: Callable[[str, bool], None] | None = None, logged: bool = True) -> Completed:
        _log(log_dir, f"Invoking command in '{cwd}': "
                      f"{format_command(command, cwd, env_delta(env, os.environ))}")
        return run_command(command, cwd=cwd, env=env, log_dir=log_dir if logged else None,
                           on_line=on_line)

    # --------------------------------------------------------------------------- pytest

    def _pytest(self, name: str, env: Mapping[str, str], target: Path,
                log_dir: Path) -> PackageTests:
        """`python -m pytest` in the source directory, as colcon-core's pytest step runs it:
        the options in `PYTEST_ADDOPTS`, so a test that parses `sys.argv` sees only
        `python -m pytest`."""
        build_dir = self.plan.workspace.build_base / name
        junit = target / "pytest.xml"
        options = [
            "--tb=short", f"--junit-xml={junit}", f"--junit-prefix={name}",
            "-o", f"cache_dir={build_dir / '.pytest_cache'}",
            # one module that cannot be imported never hides the package's other tests
            "--continue-on-collection-errors", "-p", "wsbuild.testing.missing_linters",
            *(["--wsbuild-strict-linters"] if self.request.strict_linters else []),
        ]
        command = [self.request.python_executable, "-m", "pytest"]
        env = dict(env, PYTEST_ADDOPTS=pytest_addopts(options, env.get("PYTEST_ADDOPTS", ""),
                                                      self.request.arguments("pytest", name)))
        colcon_result = build_dir / "pytest.xml"
        if colcon_result != junit and colcon_result.is_file():
            # colcon's result of this very suite: left in place it would be counted as current
            colcon_result.unlink()
        # if pytest (or wsbuild) dies before writing results, the file still says so
        placeholder = Case(name="pytest.missing_result", classname=name, outcome=CaseOutcome.ERROR,
                           message="pytest did not write a result file")
        write_junit(junit, name, [placeholder])
        before = junit.read_bytes()
        completed = self._run(command, cwd=self.plan.packages[name].path, env=env,
                              log_dir=log_dir)
        code = completed.returncode
        if junit.is_file() and junit.read_bytes() == before:
            missing = _tool_error("pytest", code, completed, "pytest.missing_result", name,
                                  "without writing results")
            result = _rewrite(junit, name, [], missing)
        else:
            result = _read_or_error(junit, name, "pytest", completed)
        if code == PYTEST_NO_TESTS and not result.counts.failed:
            return PackageTests(name, PackageStatus.NO_TESTS, result.counts,
                                result_files=(junit,), message="no tests found by pytest")
        if code != 0 and not result.counts.failed:
            # pytest failed (usage error, internal error, a signal) although no test did
            result = _rewrite(junit, name, result.cases,
                              _tool_error("pytest", code, completed, "pytest.exit_code", name))
        return _package_result(name, [result], self.request.python_executable)

    # ---------------------------------------------------------------------------- ctest

    def _ctest(self, name: str, env: Mapping[str, str], target: Path,
               log_dir: Path) -> PackageTests:
        """CTest in the build directory; each ament test's own JUnit file stands in for its
        CTest entry, the other CTest tests go to ctest.xml (so no test is counted twice)."""
        build_dir = self.plan.workspace.build_base / name
        ctest_xml = target / "ctest.xml"
        if not (build_dir / "CTestTestfile.cmake").is_file():
            ctest_xml.unlink(missing_ok=True)
            return PackageTests(name, PackageStatus.NO_TESTS,
                                message="no tests (no CTestTestfile.cmake: testing not enabled)")
        ctest = shutil.which("ctest", path=env.get("PATH")) or "ctest"
        commands = self._ctest_commands(ctest, build_dir, env, log_dir)
        if commands == {}:
            ctest_xml.unlink(missing_ok=True)
            return PackageTests(name, PackageStatus.NO_TESTS, message="no tests found by CTest")
        tag = build_dir / "Testing" / "TAG"
        if tag.is_file():
            # points colcon test-result at the Test.xml of an earlier `colcon test`: stale now
            tag.unlink()
        raw = build_dir / ".wsbuild" / "ctest-junit.xml"
        raw.parent.mkdir(parents=True, exist_ok=True)
        raw.unlink(missing_ok=True)
        command = [ctest, "-C", _cmake_config(build_dir), "--output-on-failure",
                   "--force-new-ctest-process", "--output-junit", str(raw),
                   *self.request.arguments("ctest", name)]
        verdicts: dict[str, str] = {}

        def on_line(text: str, is_err: bool) -> None:
            match = _CTEST_VERDICT.match(text)
            if match:
                verdicts[match["name"]] = match["verdict"]

        completed = self._run(command, cwd=build_dir, env=env, log_dir=log_dir, on_line=on_line)
        code = completed.returncode
        own: list[Case] = []
        files: list[ResultFile] = []
        ran: ResultFile | None = None
        if raw.is_file():
            try:
                ran = read_ctest_junit(raw)
            except (NotJUnit, BadResultFile) as exc:
                own.append(Case(name="ctest.result", classname=name, outcome=CaseOutcome.ERROR,
                                message=f"CTest wrote an unreadable result file: {exc}"))
        for case in ran.cases if ran is not None else ():
            case = replace(case, classname=name, command=commands.get(case.name, ()))
            if case.outcome is CaseOutcome.FAILURE and not case.message:
                case = replace(case, message=verdicts.get(case.name, "Failed"))
            ament = ament_result_file(case.command)
            ran_it = case.outcome in (CaseOutcome.PASSED, CaseOutcome.FAILURE)
            if ament is None or not ran_it or not ament.is_file():
                own.append(case)
                continue
            try:
                result = read_junit(ament)
            except (NotJUnit, BadResultFile) as exc:
                own.append(replace(case, outcome=CaseOutcome.ERROR,
                                   message=f"unreadable result file: {exc}"))
                continue
            files.append(_publish(result, target))
            if case.outcome is CaseOutcome.FAILURE and not result.counts.failed:
                # e.g. a crash after gtest wrote its report: CTest's verdict stands
                own.append(replace(case, message=f"{case.message}, although {ament.name} "
                                                 "reports no failures"))
        problems_seen = any(c.outcome in (CaseOutcome.FAILURE, CaseOutcome.ERROR) for c in own) \
            or any(f.counts.failed for f in files)
        if ran is None or code not in (0, CTEST_TESTS_FAILED) or \
                (code == CTEST_TESTS_FAILED and not problems_seen):
            suffix = "" if ran is not None else "without writing results"
            own.append(_tool_error("ctest", code, completed, "ctest.exit_code", name, suffix))
        if ran is not None and ran.counts.tests == 0 and not own:
            ctest_xml.unlink(missing_ok=True)
            return PackageTests(name, PackageStatus.NO_TESTS, message="no tests run by CTest")
        if own:
            write_junit(ctest_xml, name, own)
            files.insert(0, ResultFile(ctest_xml, Counts.of(own), tuple(own)))
        else:
            ctest_xml.unlink(missing_ok=True)
        return _package_result(name, files, self.request.python_executable)

    def _ctest_commands(self, ctest: str, build_dir: Path, env: Mapping[str, str],
                        log_dir: Path) -> dict[str, tuple[str, ...]] | None:
        """Every CTest test's command line (None when CTest cannot list them)."""
        lines: list[str] = []

        def on_line(text: str, is_err: bool) -> None:
            if not is_err:
                lines.append(text)

        completed = self._run([ctest, "--show-only=json-v1"], cwd=build_dir, env=env,
                              log_dir=log_dir, on_line=on_line, logged=False)
        if completed.returncode != 0:
            return None
        try:
            tests = json.loads("\n".join(lines)).get("tests", [])
        except ValueError:
            return None
        return {str(t.get("name", "")): tuple(t.get("command") or ()) for t in tests}


# "  3/4 Test  #3: name ..........***Timeout   1.00 sec": CTest's verdict, which its JUnit lacks
_CTEST_VERDICT = re.compile(
    r"^\s*\d+/\d+ Test\s+#\d+: (?P<name>\S+) \.*\s*\*\*\*(?P<verdict>.+?)\s+[\d.]+ sec")


def _cmake_config(build_dir: Path) -> str:
    """The configuration CTest runs (needed by multi-config generators), chosen as colcon does."""
    try:
        text = (build_dir / "CMakeCache.txt").read_text(errors="replace")
    except OSError:
        return "Release"
    match = re.search(r"^CMAKE_BUILD_TYPE:[A-Z]*=(.*)$", text, re.MULTILINE)
    value = match.group(1).strip() if match else ""
    return value if value in ("Debug", "MinSizeRel", "RelWithDebInfo") else "Release"


def pytest_addopts(own: Sequence[str], users: str, passed: Sequence[str]) -> str:
    """`PYTEST_ADDOPTS` for a package's pytest: wsbuild's options, then the user's own
    `PYTEST_ADDOPTS`, then `--pytest-args` (pytest lets a later option win)."""
    parts = [shlex.join(own), users.strip(), shlex.join(passed)]
    return " ".join(part for part in parts if part)


def _publish(result: ResultFile, target: Path) -> ResultFile:
    """An ament JUnit file, copied into --test-result-base when that is elsewhere."""
    if result.path.parent == target:
        return result
    copy = target / result.path.name
    shutil.copyfile(result.path, copy)
    return replace(result, path=copy)


def _tool_error(tool: str, code: int, completed: Completed, case_name: str, package: str,
                suffix: str = "") -> Case:
    message = f"{tool} {_describe_exit(code)}{' ' + suffix if suffix else ''}"
    return Case(name=case_name, classname=package, outcome=CaseOutcome.ERROR, message=message,
                details="\n".join(completed.tail[-15:]))


def _describe_exit(code: int) -> str:
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    if code == 127:
        return "could not be run"
    return f"exited with code {code}"


def _read_or_error(path: Path, name: str, tool: str, completed: Completed) -> ResultFile:
    try:
        return read_junit(path)
    except (NotJUnit, BadResultFile) as exc:
        return _rewrite(path, name, [], Case(
            name=f"{tool}.result", classname=name, outcome=CaseOutcome.ERROR,
            message=f"{tool} wrote an unreadable result file: {exc}",
            details="\n".join(completed.tail[-15:])))


def _rewrite(path: Path, name: str, cases: Sequence[Case], extra: Case) -> ResultFile:
    """Add a case to a result file, so `test-result` later sees what this run saw."""
    all_cases = (*cases, extra)
    write_junit(path, name, all_cases)
    return ResultFile(path, Counts.of(all_cases), all_cases)


def _package_result(name: str, files: Sequence[ResultFile],
                    python_executable: str) -> PackageTests:
    counts = Counts()
    problems: list[Case] = []
    missing: set[str] = set()
    for result in files:
        counts += result.counts
        problems += result.problems()
        missing.update(c.message[len(MISSING_LINTER_PREFIX):].strip() for c in result.cases
                       if c.outcome is CaseOutcome.SKIPPED
                       and c.message.startswith(MISSING_LINTER_PREFIX))
    status = PackageStatus.FAILED if counts.failed else PackageStatus.PASSED
    return PackageTests(name, status, counts, tuple(problems),
                        tuple(result.path for result in files),
                        missing_linters=tuple(sorted(missing)),
                        tooling=tooling_failures(problems, python_executable))


def _reusable_later(report: PackageTests) -> bool:
    """Only a plain pass is kept: not one that needed a retry (flaky), nor one where tests
    were skipped because their linter is missing or the tooling failed."""
    return (report.status is PackageStatus.PASSED and not report.flaky
            and not report.missing_linters and not report.tooling
            and not REGISTRY.cancelled.is_set())


def _log(log_dir: Path, line: str) -> None:
    with open(log_dir / "command.log", "a") as handle:
        handle.write(line + "\n")
