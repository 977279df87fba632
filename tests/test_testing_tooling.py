"""testing/tooling.py, testing/linters.py, testing/pytest_env.py: telling failing tests from
tooling that could not start, the linters named when missing, the ROS tests' pytest."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from wsbuild.build_types.junit import Case, CaseOutcome, Counts
from wsbuild.testing.linters import LINTER_MODULES
from wsbuild.build_types.ros_pytest import ROS_PYTEST_VAR, ros_pytest_dir, with_ros_pytest
from wsbuild.testing.results import PackageStatus, PackageTests, TestRun, summary_lines
from wsbuild.build_types.pybuild.tests import PYTEST
from wsbuild.testing.tooling import is_tooling, tooling_failures
from wsbuild.underlay.lint import LINTERS

PLUGIN_TAIL = """\
Traceback (most recent call last):
  File "pluggy/_manager.py", line 342, in _verify_hook
pluggy._manager.PluginValidationError: Plugin 'launch_testing' for hook 'pytest_pycollect_makemodule'
hookimpl definition: pytest_pycollect_makemodule(path, parent)
Argument(s) {'path'} are declared in the hookimpl but can not be found in the hookspec"""


def test_every_linter_wsbuild_stands_in_for_is_named_when_its_module_is_missing() -> None:
    assert set(LINTERS.values()) <= LINTER_MODULES


def test_a_failing_test_is_not_the_tooling() -> None:
    assert not is_tooling(Case("test_math", outcome=CaseOutcome.FAILURE, message="assert 1 == 2"))
    assert not is_tooling(Case("test_boom", outcome=CaseOutcome.ERROR, message="RuntimeError"))
    assert is_tooling(Case("test_x", outcome=CaseOutcome.ERROR, message="collection failure"))
    # a case the runner writes when its tool failed: the runner names them (TestRunner)
    tool_cases = PYTEST.tool_cases
    assert is_tooling(Case("pytest.exit_code", outcome=CaseOutcome.ERROR, message="pytest ..."),
                      tool_cases)
    assert not is_tooling(Case("pytest.exit_code", outcome=CaseOutcome.ERROR, message="x"))


def test_a_plugin_pytest_refuses_names_the_cause_and_the_ros_pytest_as_the_fix() -> None:
    case = Case("pytest.missing_result", "pkg", CaseOutcome.ERROR,
                message="pytest exited with code 3 without writing results", details=PLUGIN_TAIL)
    [failure] = tooling_failures([case], "/venv/bin/python", PYTEST.tool_cases)
    assert failure.what == "pytest exited with code 3 without writing results"
    assert failure.cause == ("PluginValidationError: Plugin 'launch_testing' for hook "
                             "'pytest_pycollect_makemodule'")
    assert failure.fix.endswith("install it for the ROS tests: wsbuild deps install (or: "
                                "/venv/bin/python -m pip install --target /venv/ros-pytest "
                                "pytest==7.4.4)")


def test_a_module_that_cannot_be_imported_names_the_module_to_install() -> None:
    case = Case("test_driver", "pkg.test", CaseOutcome.ERROR, message="collection failure",
                details="test_driver.py:1: in <module>\n    import serial\n"
                        "E   ModuleNotFoundError: No module named 'serial'")
    [failure] = tooling_failures([case], sys.executable)
    assert failure.what == "pkg.test.test_driver could not be collected"
    assert failure.cause == "ModuleNotFoundError: No module named 'serial'"
    assert failure.fix.startswith("install the Python module 'serial'")


def test_a_linter_whose_program_is_missing_names_it_and_the_command_that_installs_it() -> None:
    case = Case("cppcheck.xunit.missing_result", "demo_cpp", CaseOutcome.ERROR,
                message="The test did not generate a result file:\n\n"
                        "Could not find 'cppcheck' executable\n")
    assert is_tooling(case)
    [failure] = tooling_failures([case], sys.executable)
    assert failure.cause == "cppcheck is not installed"
    assert failure.fix.startswith("sudo apt-get install -y cppcheck" if os.geteuid()
                                  else "apt-get install -y cppcheck")
    assert "wsbuild deps install -y" in failure.fix


def test_the_summary_keeps_failing_tests_and_tooling_apart_and_names_missing_linters_once(
        tmp_path: Path) -> None:
    failure = Case("test_math", "a.test.test_a", CaseOutcome.FAILURE, message="assert 1 == 2")
    plugin = Case("pytest.missing_result", "b", CaseOutcome.ERROR,
                  message="pytest exited with code 3 without writing results", details=PLUGIN_TAIL)
    run = TestRun((
        PackageTests("a", PackageStatus.FAILED, Counts(tests=3, failures=1, skipped=1),
                     (failure,), missing_linters=("ament_copyright",)),
        PackageTests("b", PackageStatus.FAILED, Counts(tests=1, errors=1), (plugin,),
                     log_dir=tmp_path / "log" / "b",
                     tooling=tooling_failures([plugin], "/venv/bin/python", PYTEST.tool_cases)),
        PackageTests("c", PackageStatus.PASSED, Counts(tests=2, skipped=1),
                     missing_linters=("ament_copyright", "ament_xmllint")),
    ), seconds=1.0)
    assert summary_lines(run, shown=tmp_path)[3:] == [
        "  not installed, not run: ament_copyright (2 packages), ament_xmllint (1 package): "
        "counted as skipped",
        "Failed tests:",
        "  a: 3 tests, 0 errors, 1 failure, 1 skipped",
        "    FAILED a.test.test_a.test_math - assert 1 == 2",
        "Test tooling could not start (no test failed there):",
        "  b: (log: log/b/stdout_stderr.log)",
        "    pytest exited with code 3 without writing results: PluginValidationError: Plugin "
        "'launch_testing' for hook 'pytest_pycollect_makemodule'",
        "      fix: ROS 2 Jazzy's pytest plugins need pytest 7.4.4's hook arguments; install it "
        "for the ROS tests: wsbuild deps install (or: /venv/bin/python -m pip install "
        "--target /venv/ros-pytest pytest==7.4.4)",
    ]


def test_the_ros_pytest_goes_first_on_pythonpath_only_when_installed(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(ROS_PYTEST_VAR, str(tmp_path / "ros-pytest"))
    assert ros_pytest_dir(sys.executable) == tmp_path / "ros-pytest"
    env = {"PYTHONPATH": "/ws/install/pkg/lib/python3/site-packages"}
    assert with_ros_pytest(env, sys.executable) == env
    (tmp_path / "ros-pytest" / "pytest").mkdir(parents=True)
    assert with_ros_pytest(env, sys.executable)["PYTHONPATH"] == (
        f"{tmp_path / 'ros-pytest'}:/ws/install/pkg/lib/python3/site-packages")
    monkeypatch.delenv(ROS_PYTEST_VAR)
    assert ros_pytest_dir("/venv/bin/python") == Path("/venv/ros-pytest")


def test_wsbuild_test_says_in_one_line_when_the_ros_pytest_is_missing(
        make_workspace, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """`wsbuild test` of a package with pytest tests, where Jazzy's pytest is not installed
    where it looks: one warning naming the folder and how to install it; the tests still run."""
    from conftest import run_wsbuild

    ws = make_workspace({"probe": ("ament_python", [])})
    tests = ws / "src" / "probe" / "test"
    tests.mkdir()
    (tests / "test_probe.py").write_text("def test_probe():\n    assert True\n")
    built = run_wsbuild("build", cwd=ws)
    assert built.returncode == 0, built.stdout + built.stderr
    empty = tmp_path / "no-ros-pytest"
    env = {**__import__("os").environ, ROS_PYTEST_VAR: str(empty)}

    result = run_wsbuild("test", cwd=ws, env=env)

    assert result.returncode == 0, result.stdout + result.stderr
    lines = [line for line in result.stdout.splitlines() if "which ROS 2 Jazzy's pytest" in line]
    assert len(lines) == 1, result.stdout
    assert str(empty) in lines[0] and "wsbuild deps install" in lines[0]
    assert "1 test" in result.stdout
    installed = run_wsbuild("test", cwd=ws)  # the suite's venv has it: no such line
    assert "which ROS 2 Jazzy's pytest" not in installed.stdout
