"""What a test run found — each package's result and the run's — and the summary `wsbuild
test` ends with (testing/tester.py makes a package's)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.build_types.junit import Case, CaseOutcome, Counts
from wsbuild.testing.junit import display_path
from wsbuild.testing.tooling import ToolingFailure
from wsbuild.words import plural

if TYPE_CHECKING:
    from wsbuild.workspace.root import Workspace

#: failing tests listed per package in the summary (the JUnit files hold all of them)
SHOWN_PROBLEMS = 20


def results_dir(workspace: Workspace, name: str, test_result_base: Path | None) -> Path:
    """Where a package's JUnit files go: beside ament_cmake's, or under --test-result-base."""
    if test_result_base is not None:
        return test_result_base / name
    return workspace.build_base / name / "test_results" / name


class PackageStatus(Enum):
    PASSED = "passed"
    #: a test failed or errored, or the test tool itself failed
    FAILED = "failed"
    NO_TESTS = "no tests"
    #: not started: --abort-on-error after another package failed, or Ctrl-C
    NOT_RUN = "not run"
    INTERRUPTED = "interrupted"


@dataclass(frozen=True, slots=True)
class PackageTests:
    """What testing one package found."""

    package: str
    status: PackageStatus
    counts: Counts = Counts()
    #: the failed and erroring test cases
    problems: tuple[Case, ...] = ()
    result_files: tuple[Path, ...] = ()
    log_dir: Path | None = None
    message: str = ""
    attempts: int = 1
    max_attempts: int = 1
    #: passed only on a retry (--retest-until-pass), or failed after passing runs (until-fail)
    flaky: bool = False
    seconds: float = 0.0
    #: ament linters whose tests were skipped because they are not installed
    missing_linters: tuple[str, ...] = ()
    #: the test tooling failing to start (as opposed to tests failing)
    tooling: tuple[ToolingFailure, ...] = ()
    #: the result of an earlier run, reused (`log_dir` and `result_files` are that run's)
    cached: bool = False
    #: what its tests left running when their command ended, stopped: "name (pid)"
    stopped: tuple[str, ...] = ()
    #: linter tests not run because their program is not installed: (test, "program:
    #: the command that installs it")
    missing_programs: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True, slots=True)
class TestRun:
    """A `wsbuild test` run: each package's tests, how long it took, where its logs are."""

    __test__ = False  # not a pytest test class

    results: tuple[PackageTests, ...]
    seconds: float
    log_dir: Path | None = None
    interrupted: bool = False

    @property
    def counts(self) -> Counts:
        return Counts.total(result.counts for result in self.results)

    @property
    def failed(self) -> bool:
        return any(r.status in (PackageStatus.FAILED, PackageStatus.NOT_RUN,
                                PackageStatus.INTERRUPTED) for r in self.results)


def problem_text(counts: Counts) -> str:
    """`2 failures, 1 error`, only the non-zero ones."""
    parts = []
    if counts.failures:
        parts.append(plural(counts.failures, "failure"))
    if counts.errors:
        parts.append(plural(counts.errors, "error"))
    return ", ".join(parts)


def summary_lines(run: TestRun, *, shown: Path) -> list[str]:
    """The end of `wsbuild test`: totals, packages by outcome, every failing test with its log.

    Paths are shown relative to `shown` (the current directory) when inside it.
    """
    tested = [r for r in run.results if r.status in
              (PackageStatus.PASSED, PackageStatus.FAILED, PackageStatus.NO_TESTS)]
    lines = [f"Summary: {plural(len(tested), 'package')} tested, {run.counts.describe()} "
             f"[{run.seconds:.2f}s]"]
    for status, label in ((PackageStatus.PASSED, "passed"),
                          (PackageStatus.NO_TESTS, "without tests"),
                          (PackageStatus.FAILED, "failed"),
                          (PackageStatus.INTERRUPTED, "aborted"),
                          (PackageStatus.NOT_RUN, "not tested")):
        names = sorted(r.package for r in run.results if r.status is status)
        if names:
            lines.append(f"  {plural(len(names), 'package')} {label}: {' '.join(names)}")
        cached = sorted(r.package for r in run.results if r.status is status and r.cached)
        if cached:
            lines.append(f"    of which cached (nothing their tests observe changed; "
                         f"--no-test-cache runs them): {' '.join(cached)}")
    for result in run.results:
        if result.flaky:
            lines.append(f"  flaky: {result.package} {result.status.value} on attempt "
                         f"{result.attempts} of {result.max_attempts}")
    lines += _missing_linter_lines(run.results)
    for result in run.results:
        if result.stopped:
            lines.append(f"  {result.package}: stopped {plural(len(result.stopped), 'process', 'processes')} "
                         f"its tests left running: {', '.join(result.stopped)}")
    failed = [r for r in run.results if r.status is PackageStatus.FAILED]
    tested_failed = [r for r in failed
                     if any(not _tooling(r, c) for c in r.problems) or not r.tooling]
    if tested_failed:
        lines.append("Failed tests:")
    for result in tested_failed:
        lines.append(f"  {result.package}: {result.counts.describe()}{_log_of(result, shown)}")
        problems = [c for c in result.problems if not _tooling(result, c)]
        for case in problems[:SHOWN_PROBLEMS]:
            verdict = "ERROR" if case.outcome is CaseOutcome.ERROR else "FAILED"
            lines.append(f"    {verdict} {case.full_name} - {case.headline}")
        if len(problems) > SHOWN_PROBLEMS:
            lines.append(f"    ... and {len(problems) - SHOWN_PROBLEMS} more")
        if not result.problems and result.message:
            lines.append(f"    {result.message}")
    broken = [r for r in failed if r.tooling]
    if broken:
        lines.append("Test tooling could not start (no test failed there):")
    for result in broken:
        lines.append(f"  {result.package}:{_log_of(result, shown)}")
        for failure in result.tooling:
            lines.append(f"    {failure.what}: {failure.cause}")
            lines.append(f"      fix: {failure.fix}")
    return lines


def cached_text(result: PackageTests, shown: Path) -> str:
    """`cached: 3 tests, ... (log: ..., results: ...)`: a reused result, as it was."""
    places = []
    if result.log_dir is not None:
        places.append(f"log: {display_path(result.log_dir / 'stdout_stderr.log', shown)}")
    folders = sorted({display_path(path.parent, shown) for path in result.result_files})
    if folders:
        places.append(f"results: {' '.join(folders)}")
    where = f" ({', '.join(places)})" if places else ""
    return f"cached: {result.counts.describe()}{where}"


def _log_of(result: PackageTests, shown: Path) -> str:
    if result.log_dir is None:
        return ""
    return f" (log: {display_path(result.log_dir / 'stdout_stderr.log', shown)})"


def _missing_linter_lines(results: Sequence[PackageTests]) -> list[str]:
    """One line per run naming the linters not installed, as the build names its stand-ins."""
    users: dict[str, list[str]] = {}
    for result in results:
        for linter in result.missing_linters:
            users.setdefault(linter, []).append(result.package)
    lines = []
    if users:
        listed = ", ".join(f"{linter} ({plural(len(packages), 'package')})"
                           for linter, packages in sorted(users.items()))
        lines.append(f"  not installed, not run: {listed}: counted as skipped")
    programs: dict[tuple[str, str], list[str]] = {}
    for result in results:
        for test, program in result.missing_programs:
            programs.setdefault((test, program), []).append(result.package)
    for (test, program), packages in sorted(programs.items()):
        name, _, install = program.partition(": ")
        lines.append(f"  not installed, not run: the {test} test of {', '.join(packages)} "
                     f"({name} is not installed): counted as skipped; install it: {install}; "
                     f"or leave the test out: --ctest-args -E {test}; --require-linters makes "
                     "this a failure")
    return lines


def _tooling(result: PackageTests, case: Case) -> bool:
    """Whether a failing case of the package stands for its test tooling failing to start."""
    return any(failure.case == case.full_name for failure in result.tooling)
