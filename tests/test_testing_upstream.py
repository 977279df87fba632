"""`wsbuild test` on packages written as upstream ROS 2 Python packages are, on the pip-only
underlay: the three linter tests of `ros2 pkg create` (ament_copyright has no distribution),
a pytest plugin from a test dependency with launch_testing's pytest 7 hook signature, and a
failing unit test. The plugin and launch-test packages are the corpus's own."""

from __future__ import annotations

import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from test_build_helpers import REQUIRES_ROS, clean_env, output, wsbuild

pytestmark = [*REQUIRES_ROS, pytest.mark.slow, pytest.mark.xdist_group("upstream_tests")]

DATA = Path(__file__).parent / "data"
CORPUS = DATA / "corpus" / "src"
PACKAGES = ("corpus_launch_testing", "corpus_launch_checks", "failing_math")


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    ws = tmp_path_factory.mktemp("upstream") / "ws"
    for name in PACKAGES[:2]:
        shutil.copytree(CORPUS / name, ws / "src" / name)
    shutil.copytree(DATA / "failing_tests" / "failing_math", ws / "src" / "failing_math")
    result = wsbuild("build", cwd=ws)
    assert result.returncode == 0, output(result)
    return ws


@pytest.fixture(scope="module")
def tested(built: Path) -> subprocess.CompletedProcess[str]:
    return wsbuild("test", cwd=built)


def _cases(ws: Path, package: str) -> dict[str, tuple[str, str]]:
    """test name -> (outcome, message), from the package's JUnit files."""
    found: dict[str, tuple[str, str]] = {}
    for path in (ws / "build" / package / "test_results").rglob("*.xml"):
        for case in ET.parse(path).getroot().iter("testcase"):
            state, message = "passed", ""
            for tag in ("failure", "error", "skipped"):
                element = case.find(tag)
                if element is not None:
                    state, message = tag, element.get("message", "")
            found[case.get("name", "")] = (state, message)
    return found


def _summary(result: subprocess.CompletedProcess[str]) -> list[str]:
    lines = result.stdout.splitlines()
    return lines[next(i for i, line in enumerate(lines) if line.startswith("Summary:")):]


def test_the_real_tests_and_linters_run_and_a_missing_linter_is_skipped_as_such(
        built: Path, tested: subprocess.CompletedProcess[str]) -> None:
    checks = _cases(built, "corpus_launch_checks")
    assert checks == {
        "test_copyright": ("skipped", "not installed, not run: ament_copyright"),
        "test_flake8": ("passed", ""),
        "test_pep257": ("passed", ""),
        "test_ticks_count_from_one": ("passed", ""),
        "test_no_ticks_for_zero": ("passed", ""),
        # the launch-style module, collected by the test dependency's pytest 7 style plugin
        "test_counter_launch": ("passed", ""),
    }
    summary = _summary(tested)
    assert "  not installed, not run: ament_copyright (3 packages): counted as skipped" in summary
    log = next((built / "log").glob("test_*/corpus_launch_checks/stdout_stderr.log")).read_text()
    assert "pytest-7.4.4" in log and "corpus_launch_testing-0.9.0" in log  # the plugin loaded


def test_a_failing_unit_test_fails_the_run_and_is_named(
        built: Path, tested: subprocess.CompletedProcess[str]) -> None:
    assert tested.returncode == 1, output(tested)
    summary = _summary(tested)
    assert re.fullmatch(r"Summary: 3 packages tested, 16 tests, 0 errors, 1 failure, 3 skipped "
                        r"\[\d+\.\d\ds\]", summary[0])
    assert summary[1:3] == ["  2 packages passed: corpus_launch_checks corpus_launch_testing",
                            "  1 package failed: failing_math"]
    assert "Failed tests:" in summary and "Test tooling could not start" not in tested.stdout
    assert ("    FAILED failing_math.test.test_arithmetic."
            "test_median_of_even_count_is_the_average_of_the_middle_two - assert 3 == 2.5"
            ) in summary
    math = _cases(built, "failing_math")
    assert math["test_mean_of_three"] == ("passed", "")
    assert math["test_flake8"] == ("passed", "") and math["test_pep257"] == ("passed", "")


def test_strict_linters_makes_the_missing_linter_an_error_and_the_rest_still_runs(
        built: Path) -> None:
    result = wsbuild("test", "--packages-select", "corpus_launch_checks", "--strict-linters",
                     "--test-result-base", "strict", cwd=built)
    assert result.returncode == 1, output(result)
    summary = _summary(result)
    assert re.fullmatch(r"Summary: 1 package tested, 6 tests, 1 error, 0 failures, 0 skipped "
                        r"\[\d+\.\d\ds\]", summary[0])
    start = summary.index("Test tooling could not start (no test failed there):")
    assert summary[start + 2:start + 4] == [
        "    corpus_launch_checks.test.test_copyright could not be collected: No module named "
        "'ament_copyright': the ament linter is not installed (--strict-linters)",
        "      fix: install the linter, or test without --strict-linters to count its tests as "
        "skipped",
    ]


def test_strict_linters_from_the_defaults_file(built: Path) -> None:
    (built / "wsbuild.yaml").write_text("test:\n  strict-linters: true\n")
    try:
        result = wsbuild("test", "--packages-select", "corpus_launch_testing",
                         "--test-result-base", "strict_defaults", cwd=built)
    finally:
        (built / "wsbuild.yaml").unlink()
    assert result.returncode == 1, output(result)
    assert "could not be collected: No module named 'ament_copyright'" in result.stdout


def test_a_pytest_that_refuses_the_plugin_is_the_tooling_failing_with_the_fix(
        built: Path) -> None:
    # without the ROS tests' pytest, the venv's own pytest (9) runs and refuses the plugin
    env = clean_env(WSBUILD_ROS_PYTEST=str(built / "no-such-dir"))
    result = wsbuild("test", "--packages-select", "corpus_launch_checks",
                     "--test-result-base", "pytest9", cwd=built, env=env)
    assert result.returncode == 1, output(result)
    summary = _summary(result)
    assert "Failed tests:" not in summary
    start = summary.index("Test tooling could not start (no test failed there):")
    cause, fix = summary[start + 2:start + 4]
    assert cause.startswith("    pytest exited with code 3 without writing results: "
                            "PluginValidationError: Plugin 'corpus_launch_testing' for hook "
                            "'pytest_pycollect_makemodule'")
    assert fix.startswith("      fix: ROS 2 Jazzy's pytest plugins need pytest 7.4.4's hook "
                          "arguments; install it for the ROS tests: ")
    assert fix.endswith(f" -m pip install --target {built / 'no-such-dir'} pytest==7.4.4)")
    assert "install it for the ROS tests: wsbuild deps install (or: " in fix
