"""The Python build types' tests: `python -m pytest` in the source directory, as colcon-core's
pytest step runs it, its JUnit file read back."""

from __future__ import annotations

import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from wsbuild.build_types import Command
from wsbuild.build_types.junit import Case, CaseOutcome, write_junit
from wsbuild.build_types.test_runner import (
    TestContext,
    TestOutcome,
    TestRunnerBase,
    read_or_error,
    rewrite,
    tool_error,
)

#: pytest's exit code when it collected no tests
PYTEST_NO_TESTS = 5
#: the pytest plugin that turns a test of a missing ament linter into a skip (a module of
#: wsbuild the packages' test interpreter imports by name)
MISSING_LINTERS_PLUGIN = "wsbuild.testing.missing_linters"


@dataclass(frozen=True, slots=True)
class PytestRunner(TestRunnerBase):
    """pytest, against the package's install; its options in `PYTEST_ADDOPTS`, so a test that
    parses `sys.argv` sees only `python -m pytest`."""

    name: str = "pytest"

    @property
    def tool_cases(self) -> frozenset[str]:
        return frozenset({"pytest.exit_code", "pytest.missing_result", "pytest.result"})

    def environment(self, env: Mapping[str, str], python_executable: str) -> dict[str, str]:
        from wsbuild.build_types.ros_pytest import with_ros_pytest  # lazy: off a Python-only build

        return with_ros_pytest(env, python_executable)

    def command(self, ctx: TestContext) -> Command:
        junit = ctx.results_dir / "pytest.xml"
        options = [
            "--tb=short", f"--junit-xml={junit}", f"--junit-prefix={ctx.name}",
            "-o", f"cache_dir={ctx.build_dir / '.pytest_cache'}",
            # one module that cannot be imported never hides the package's other tests
            "--continue-on-collection-errors", "-p", MISSING_LINTERS_PLUGIN,
            *(["--wsbuild-strict-linters"] if ctx.strict_linters else []),
        ]
        addopts = pytest_addopts(options, ctx.environ.get("PYTEST_ADDOPTS", ""), ctx.arguments)
        return Command((ctx.python_executable, "-m", "pytest"), ctx.package.path,
                       env={"PYTEST_ADDOPTS": addopts})

    def run(self, ctx: TestContext) -> TestOutcome:
        name = ctx.name
        junit = ctx.results_dir / "pytest.xml"
        colcon_result = ctx.build_dir / "pytest.xml"
        if colcon_result != junit and colcon_result.is_file():
            # colcon's result of this very suite: left in place it would be counted as current
            colcon_result.unlink()
        # if pytest (or wsbuild) dies before writing results, the file still says so
        placeholder = Case(name="pytest.missing_result", classname=name,
                           outcome=CaseOutcome.ERROR, message="pytest did not write a result file")
        write_junit(junit, name, [placeholder])
        before = junit.read_bytes()
        completed = ctx.run(self.command(ctx))
        code = completed.returncode
        if junit.is_file() and junit.read_bytes() == before:
            missing = tool_error("pytest", code, completed, "pytest.missing_result", name,
                                 "without writing results")
            result = rewrite(junit, name, [], missing)
        else:
            result = read_or_error(junit, name, "pytest", completed)
        if code == PYTEST_NO_TESTS and not result.counts.failed:
            return TestOutcome((result,), no_tests="no tests found by pytest")
        if code != 0 and not result.counts.failed:
            # pytest failed (usage error, internal error, a signal) although no test did
            result = rewrite(junit, name, result.cases,
                             tool_error("pytest", code, completed, "pytest.exit_code", name))
        return TestOutcome((result,))


def pytest_addopts(own: Sequence[str], users: str, passed: Sequence[str]) -> str:
    """`PYTEST_ADDOPTS` for a package's pytest: wsbuild's options, then the user's own
    `PYTEST_ADDOPTS`, then `--pytest-args` (pytest lets a later option win)."""
    parts = [shlex.join(own), users.strip(), shlex.join(passed)]
    return " ".join(part for part in parts if part)


PYTEST = PytestRunner()
