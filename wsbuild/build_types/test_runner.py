"""A build type's test runner: what it is (`TestRunner`), what it works with (`TestContext`),
what it returns (`TestOutcome`), and the result-file helpers the built-in runners share.

A build type names its runner (`BuildType.test_runner`, None: its packages have no tests). The
runner knows its tool's command line, how to read what the tool wrote into JUnit results
(junit.py), and what else its tests observe (`KeyInputs`, for the cached result's key);
testing/ keeps what every runner shares: which packages run, in what order and environment,
retries, the cached result and the summary. The built-ins: pytest's
(build_types/pybuild/tests.py) for the Python types, CTest's (ctest.py) for the CMake ones. A
third-party build type brings its own: derive it from `TestRunnerBase` and give it a `name`, a
`command` and a `run`.
"""

from __future__ import annotations

import signal
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from wsbuild.build_types import Command
from wsbuild.build_types.junit import BadResultFile, Case, CaseOutcome, Counts, NotJUnit, \
    ResultFile, read_junit, write_junit
from wsbuild.workspace.model import Package

if TYPE_CHECKING:
    from wsbuild.engine.process import Completed


class RunTestCommand(Protocol):
    """Runs a test command in the package's test environment (plus `command.env`), logging
    the command line and its output (`logged=False`: only the line) into the package's log."""

    def __call__(self, command: Command, *, on_line: Callable[[str, bool], None] | None = None,
                 logged: bool = True) -> Completed: ...


@dataclass(frozen=True, slots=True)
class TestContext:
    """What a test runner gets to work with for one package."""

    __test__ = False  # not a pytest test class

    package: Package
    build_dir: Path
    #: where its JUnit files go: <build>/<pkg>/test_results/<pkg>/, or --test-result-base/<pkg>/
    results_dir: Path
    #: the environment its tests run in (its install after its test closure's)
    environ: Mapping[str, str]
    #: the arguments for this runner's tool: the command line's (`--pytest-args`, ...), then
    #: the ones the package's colcon.meta adds
    arguments: tuple[str, ...]
    python_executable: str
    #: a test of an ament linter that is not installed is an error, not a skip
    strict_linters: bool
    run: RunTestCommand

    @property
    def name(self) -> str:
        return self.package.name


@dataclass(frozen=True, slots=True)
class TestOutcome:
    """What one run of a package's tests found: its result files, or that it has none."""

    __test__ = False  # not a pytest test class

    files: tuple[ResultFile, ...] = ()
    #: why the package has no tests to run ("" when it has): then `files` may still hold what
    #: the tool wrote, and the package neither passes nor fails
    no_tests: str = ""


@dataclass(frozen=True, slots=True)
class KeyInputs:
    """What a runner's tests observe beyond what every test run does (the packages' builds,
    sources, environment, the interpreter): they enter the cached result's key."""

    #: each tool's path and stat signature ("path:signature")
    tools: tuple[str, ...] = ()
    #: files whose stat signature enters the key (absent files count too)
    files: tuple[Path, ...] = ()


class TestRunner(Protocol):
    """How a build type's tests run and what their results say."""

    @property
    def name(self) -> str:
        """The tool's name: labels the step and picks its arguments (`--pytest-args` are
        "pytest"'s)."""
        ...

    def built(self, build_dir: Path) -> bool:
        """Whether the package's build left what its tests need (CTest: a configured tree)."""
        ...

    def tests_in_build_tree(self, build_dir: Path) -> bool:
        """Whether, after a build, the package's tests run from what the build left in its
        build directory (CTest's test programs). The build cache brings back a package's
        install only: `wsbuild test` builds such a package's tree again before its tests
        (verbs/test.py), with the options its record holds."""
        ...

    def key_inputs(self, ctx: TestContext) -> KeyInputs:
        """What its tests observe beyond what every test run does (for the cached result)."""
        ...

    def environment(self, env: Mapping[str, str], python_executable: str) -> dict[str, str]:
        """The environment its tool runs in: the package's test environment (its install and
        its dependencies' applied) and what the tool itself needs (pytest's runner: the ROS
        tests' pytest first on PYTHONPATH)."""
        ...

    @property
    def tool_cases(self) -> frozenset[str]:
        """The names of the cases it writes when its tool itself failed (`tool_error`): the
        summary tells them apart from failing tests (testing/tooling.py)."""
        ...

    def command(self, ctx: TestContext) -> Command:
        """The command that runs the package's tests, as data (logged as a reproduce line)."""
        ...

    def run(self, ctx: TestContext) -> TestOutcome:
        """Run the package's tests once and read their results (JUnit files in
        `ctx.results_dir`); a failing tool is a result (`tool_error`), not an exception."""
        ...


@dataclass(frozen=True, slots=True)
class TestRunnerBase:
    """Defaults for a test runner: nothing to wait for, nothing observed beyond the common.
    Subclass it and give `name`, `command` and `run`."""

    __test__ = False  # not a pytest test class

    name: str = ""

    def built(self, build_dir: Path) -> bool:
        return True

    def tests_in_build_tree(self, build_dir: Path) -> bool:
        return False

    def key_inputs(self, ctx: TestContext) -> KeyInputs:
        return KeyInputs()

    def environment(self, env: Mapping[str, str], python_executable: str) -> dict[str, str]:
        return dict(env)

    @property
    def tool_cases(self) -> frozenset[str]:
        return frozenset()

    def command(self, ctx: TestContext) -> Command:
        raise NotImplementedError(f"test runner '{self.name}' defines no command")

    def run(self, ctx: TestContext) -> TestOutcome:
        raise NotImplementedError(f"test runner '{self.name}' cannot run")


# ----------------------------------------------------------------- results when the tool fails


def tool_error(tool: str, code: int, completed: Completed, case_name: str, package: str,
               suffix: str = "") -> Case:
    """A case standing for the tool itself failing (testing/tooling.py tells it apart)."""
    message = f"{tool} {describe_exit(code)}{' ' + suffix if suffix else ''}"
    return Case(name=case_name, classname=package, outcome=CaseOutcome.ERROR, message=message,
                details="\n".join(completed.tail[-15:]))


def describe_exit(code: int) -> str:
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    if code == 127:
        return "could not be run"
    return f"exited with code {code}"


def read_or_error(path: Path, name: str, tool: str, completed: Completed) -> ResultFile:
    """The tool's JUnit file, or one saying the tool wrote an unreadable one."""
    try:
        return read_junit(path)
    except (NotJUnit, BadResultFile) as exc:
        return rewrite(path, name, [], Case(
            name=f"{tool}.result", classname=name, outcome=CaseOutcome.ERROR,
            message=f"{tool} wrote an unreadable result file: {exc}",
            details="\n".join(completed.tail[-15:])))


def rewrite(path: Path, name: str, cases: Sequence[Case], extra: Case) -> ResultFile:
    """Add a case to a result file, so `test-result` later sees what this run saw."""
    all_cases = (*cases, extra)
    write_junit(path, name, all_cases)
    return ResultFile(path, Counts.of(all_cases), all_cases)
