"""build_types/test_runner.py, pybuild/tests.py, ctest.py: each build type names its test runner,
whose command is data (a `Command`) built from what the package's context holds; the runs
themselves are tests/test_testing.py's (real pytest and CTest)."""

from __future__ import annotations

import shlex
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest

from wsbuild.build_types import BUILTIN, Command, get_build_type
from wsbuild.build_types.ctest import CTEST
from wsbuild.build_types.pybuild.tests import PYTEST
from wsbuild.build_types.test_runner import TestContext
from wsbuild.engine.process import Completed
from wsbuild.workspace.model import Package


def _context(tmp_path: Path, *, arguments: tuple[str, ...] = (),
             environ: dict[str, str] | None = None) -> tuple[TestContext, list[Command]]:
    ran: list[Command] = []

    def run(command: Command, *, on_line: Callable[[str, bool], None] | None = None,
            logged: bool = True) -> Completed:
        ran.append(command)
        return Completed(0, (), ())

    package = Package("pkg", tmp_path / "src" / "pkg", "ament_python")
    ctx = TestContext(package=package, build_dir=tmp_path / "build" / "pkg",
                      results_dir=tmp_path / "results" / "pkg", environ=environ or {},
                      arguments=arguments, python_executable="/venv/bin/python",
                      strict_linters=False, run=run)
    return ctx, ran


def test_each_built_in_build_type_names_the_runner_of_its_tests() -> None:
    runners = {name: get_build_type(name).test_runner for name in BUILTIN}
    assert runners == {"ament_cmake": CTEST, "cmake": CTEST, "ament_python": PYTEST,
                       "python": PYTEST}
    assert (PYTEST.name, CTEST.name) == ("pytest", "ctest")


def test_pytests_command_puts_its_options_first_then_the_users_then_the_arguments(
        tmp_path: Path) -> None:
    ctx, _ = _context(tmp_path, arguments=("-k", "a and b"),
                      environ={"PYTEST_ADDOPTS": "-x"})
    command = PYTEST.command(ctx)
    assert (command.argv, command.cwd) == (("/venv/bin/python", "-m", "pytest"),
                                           tmp_path / "src" / "pkg")
    options = shlex.split(command.env["PYTEST_ADDOPTS"])
    assert f"--junit-xml={tmp_path / 'results' / 'pkg' / 'pytest.xml'}" in options
    # the user's PYTEST_ADDOPTS, then the arguments: pytest lets a later option win
    assert options[-3:] == ["-x", "-k", "a and b"]


def test_ctests_command_runs_the_configuration_the_cache_names_with_the_arguments_last(
        tmp_path: Path) -> None:
    ctx, _ = _context(tmp_path, arguments=("-R", "^fine$"))
    assert not CTEST.built(ctx.build_dir)
    ctx.build_dir.mkdir(parents=True)
    (ctx.build_dir / "CMakeCache.txt").write_text("CMAKE_BUILD_TYPE:STRING=Debug\n")
    assert CTEST.built(ctx.build_dir)
    command = CTEST.command(ctx)
    assert command.cwd == ctx.build_dir
    assert command.argv[1:3] == ("-C", "Debug")
    assert command.argv[-2:] == ("-R", "^fine$")


@pytest.mark.parametrize("value,config", [("", "Release"), ("RelWithDebInfo", "RelWithDebInfo"),
                                          ("Coverage", "Release")])
def test_ctest_runs_the_configurations_colcon_runs(tmp_path: Path, value: str,
                                                    config: str) -> None:
    ctx, _ = _context(tmp_path)
    ctx.build_dir.mkdir(parents=True)
    (ctx.build_dir / "CMakeCache.txt").write_text(f"CMAKE_BUILD_TYPE:STRING={value}\n")
    assert CTEST.command(ctx).argv[1:3] == ("-C", config)


def test_a_package_without_ctest_file_has_no_tests_and_runs_nothing(tmp_path: Path) -> None:
    ctx, ran = _context(tmp_path)
    outcome = CTEST.run(ctx)
    assert outcome.no_tests.startswith("no tests (no CTestTestfile.cmake")
    assert ran == []


def test_ctests_key_names_its_binary_and_the_files_its_tests_read(tmp_path: Path) -> None:
    ctx, _ = _context(tmp_path, environ={"PATH": "/nonexistent"})
    observed = CTEST.key_inputs(ctx)
    assert observed.files == (ctx.build_dir / "CTestTestfile.cmake",
                              ctx.build_dir / ".ninja_log")
    assert len(observed.tools) == 1
    assert PYTEST.key_inputs(ctx).files == ()


def test_ctest_results_stand_when_ctest_cannot_list_its_tests(tmp_path: Path) -> None:
    """`ctest --show-only` failing (an old CTest, a broken test file) leaves the run's own
    results standing: no ament file can stand in, each CTest entry counts."""
    from wsbuild.build_types.junit import Case, CaseOutcome, Counts, write_junit

    ctx, ran = _context(tmp_path)
    ctx.build_dir.mkdir(parents=True)
    (ctx.build_dir / "CTestTestfile.cmake").write_text("add_test(ok true)\n")

    def run(command: Command, *, on_line: Callable[[str, bool], None] | None = None,
            logged: bool = True) -> Completed:
        ran.append(command)
        if "--show-only=json-v1" in command.argv:
            return Completed(1, ("cannot list",), ())
        junit = Path(command.argv[command.argv.index("--output-junit") + 1])
        write_junit(junit, "pkg", [Case(name="ok", outcome=CaseOutcome.PASSED)])
        return Completed(0, (), ())

    ctx = replace(ctx, run=run)
    ctx.results_dir.mkdir(parents=True)
    outcome = CTEST.run(ctx)
    assert [f.counts for f in outcome.files] == [Counts(tests=1)]
    assert outcome.files[0].path == ctx.results_dir / "ctest.xml"


def test_a_test_run_reaches_the_runners_only_through_the_build_types() -> None:
    """testing/ keeps what every runner shares: no module of a `wsbuild test` run imports a
    runner's module (it asks `get_build_type(...).test_runner`), so a plugin's runner is run
    as pytest's is. (testing/junit.py, `test-result`'s walk, reads CTest's files by name: they
    may be colcon's.)"""
    import ast

    testing = Path(__file__).resolve().parent.parent / "wsbuild" / "testing"
    runners = {"wsbuild.build_types.ctest", "wsbuild.build_types.pybuild.tests"}
    found = []
    for path in sorted(set(testing.glob("*.py")) - {testing / "junit.py"}):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            found += [f"{path.name}:{node.lineno} {name}" for name in names if name in runners]
    assert found == []
