"""`wsbuild test` and `wsbuild test-result` end to end: exit codes, JUnit files, summary lines."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from conftest import run_wsbuild, sigint_at_default, write_package
from wsbuild.build_types.junit import Counts, read_junit
from wsbuild.underlay.detect import find_venv_underlay

TESTS = Path(__file__).resolve().parent
SAMPLE_WS = TESTS.parent / "sample_ws"
UNDERLAY = find_venv_underlay(os.environ, sys.executable)


# ---------------------------------------------------------------- the command line under test


def cli_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "wsbuild", *args]


def environment() -> dict[str, str]:
    env = dict(os.environ)
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    env.update(ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               ROS_DOMAIN_ID=str(80 + int(worker.removeprefix("gw") or 0)))
    return env


def cli(*args: str, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cli_command(*args), cwd=cwd, env=environment(), capture_output=True,
                          text=True, timeout=timeout)


def lines(result: subprocess.CompletedProcess[str]) -> list[str]:
    return result.stdout.splitlines()


# ------------------------------------------------------------------------------ workspace


def _tests(package: Path, name: str, text: str) -> None:
    (package / "test").mkdir(exist_ok=True)
    (package / "test" / name).write_text(text)


CM_CMAKELISTS = """cmake_minimum_required(VERSION 3.14)
project(cm NONE)
enable_testing()
add_test(NAME ok COMMAND true)
install(FILES package.xml DESTINATION share/cm)
"""


def _workspace(root: Path) -> Path:
    src = root / "src"
    _tests(write_package(src, "good"), "test_good.py", "def test_one():\n    assert True\n")
    _tests(write_package(src, "bad"), "test_bad.py",
           "def test_fine():\n    pass\n\n"
           "def test_math():\n    assert 1 + 1 == 3, 'arithmetic is broken'\n")
    _tests(write_package(src, "broken"), "test_broken.py",
           "import not_a_module\n\ndef test_never():\n    pass\n")
    write_package(src, "empty")
    (write_package(src, "cm", "cmake") / "CMakeLists.txt").write_text(CM_CMAKELISTS)
    built = run_wsbuild("build", cwd=root)
    assert built.returncode == 0, built.stdout + built.stderr
    return root


Tested = tuple[Path, subprocess.CompletedProcess[str]]


@pytest.fixture(scope="module")
def tested(tmp_path_factory: pytest.TempPathFactory) -> Tested:
    """A workspace with a passing, a failing, an erroring, a CMake and a test-less package,
    built and then tested once with `wsbuild test`."""
    root = _workspace(tmp_path_factory.mktemp("verbs_ws"))
    return root, cli("test", cwd=root)


def test_a_failing_or_erroring_test_fails_the_run(tested: Tested) -> None:
    root, result = tested
    assert result.returncode == 1, result.stdout + result.stderr
    out = lines(result)
    summary = next(line for line in out if line.startswith("Summary:"))
    assert re.fullmatch(r"Summary: 5 packages tested, 5 tests, 1 error, 1 failure, 0 skipped "
                        r"\[\d+\.\d\ds\]", summary)
    assert out[out.index(summary) + 1:out.index(summary) + 5] == [
        "  2 packages passed: cm good",
        "  1 package without tests: empty",
        "  2 packages failed: bad broken",
        "Failed tests:",
    ]
    assert "    FAILED bad.test.test_bad.test_math - AssertionError: arithmetic is broken" in out
    # a module that cannot be imported is the tooling failing, told apart from failing tests
    tooling = out.index("Test tooling could not start (no test failed there):")
    assert out.index("Failed tests:") < tooling
    assert re.fullmatch(r"  broken: \(log: .*\)", out[tooling + 1])
    assert out[tooling + 2:tooling + 4] == [
        "    broken.test.test_broken could not be collected: "
        "ModuleNotFoundError: No module named 'not_a_module'",
        "      fix: install the Python module 'not_a_module' (pip, or build the workspace package "
        "providing it and declare it as a <test_depend>)",
    ]
    assert "[empty] no tests found by pytest" in out
    assert any(line.startswith("Failed   <<< bad [") for line in out)
    logs = dict(re.findall(r"^  (\w+): .*\(log: (.*)\)$", result.stdout, re.MULTILINE))
    assert sorted(logs) == ["bad", "broken"]
    assert "arithmetic is broken" in (root / logs["bad"]).read_text()
    assert "not_a_module" in (root / logs["broken"]).read_text()


def test_results_are_junit_files_under_each_build_directory(tested: Tested) -> None:
    root, _ = tested
    expected = {"good": ("pytest.xml", Counts(tests=1)),
                "bad": ("pytest.xml", Counts(tests=2, failures=1)),
                "broken": ("pytest.xml", Counts(tests=1, errors=1)),
                "empty": ("pytest.xml", Counts()),
                "cm": ("ctest.xml", Counts(tests=1))}
    for name, (filename, counts) in expected.items():
        path = root / "build" / name / "test_results" / name / filename
        assert read_junit(path).counts == counts, name


def test_passing_packages_and_packages_without_tests_exit_zero(tested: Tested) -> None:
    root, _ = tested
    result = cli("test", "--packages-select", "good", "cm", "empty",
                 "--test-result-base", "passing", cwd=root)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "  1 package without tests: empty" in lines(result)
    assert (root / "passing" / "good" / "pytest.xml").is_file()  # colcon's layout
    shown = cli("test-result", "--test-result-base", "passing", cwd=root)
    assert (shown.returncode, lines(shown)) == \
        (0, ["Summary: 2 tests, 0 errors, 0 failures, 0 skipped"])


def test_test_result_reads_the_results_back_and_fails_on_failures(tested: Tested) -> None:
    root, _ = tested
    result = cli("test-result", cwd=root)
    assert result.returncode == 1
    assert lines(result) == [
        "build/bad/test_results/bad/pytest.xml: 2 tests, 0 errors, 1 failure, 0 skipped",
        "build/broken/test_results/broken/pytest.xml: 1 test, 1 error, 0 failures, 0 skipped",
        "",
        "Summary: 5 tests, 1 error, 1 failure, 0 skipped",
    ]
    every = cli("test-result", "--all", cwd=root)
    assert "build/cm/test_results/cm/ctest.xml: 1 test, 0 errors, 0 failures, 0 skipped" \
        in lines(every)
    verbose = lines(cli("test-result", "--verbose", cwd=(root / "src")))  # found from below
    at = verbose.index("- bad.test.test_bad test_math")
    assert verbose[at + 1:at + 3] == ["  <<< failure message",
                                      "    AssertionError: arithmetic is broken"]
    files = cli("test-result", "--result-files-only", cwd=root)
    assert lines(files) == ["build/bad/test_results/bad/pytest.xml",
                            "build/broken/test_results/broken/pytest.xml"]


def test_tool_arguments_may_start_with_a_dash(tested: Tested) -> None:
    root, _ = tested
    result = cli("test", "--pytest-args", "-k", "test_fine", "--packages-select", "bad",
                 "--test-result-base", "subset", cwd=root)
    assert result.returncode == 0, result.stdout + result.stderr
    assert read_junit(root / "subset" / "bad" / "pytest.xml").counts == Counts(tests=1)
    result = cli("test", "--ctest-args", "-R", "^no_such_test$", "--", "--packages-select", "cm",
                 "--test-result-base", "subset", cwd=root)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "  1 package without tests: cm" in lines(result)


def test_a_test_that_parses_sys_argv_sees_only_python_m_pytest(tmp_path: Path) -> None:
    """wsbuild's pytest options go into PYTEST_ADDOPTS, as colcon's do (ros2cli's
    test_direct.py parses the command line), after the user's own PYTEST_ADDOPTS."""
    _tests(write_package(tmp_path / "src", "argv"), "test_argv.py",
           "import argparse\nimport sys\n\n"
           "def test_parses_its_command_line():\n"
           "    assert sys.argv[1:] == []\n"
           "    argparse.ArgumentParser().parse_args()\n\n"
           "def test_left_out_by_the_user():\n"
           "    assert False, 'the user deselected this one'\n")
    built = run_wsbuild("build", cwd=tmp_path)
    assert built.returncode == 0, built.stdout + built.stderr
    result = subprocess.run(cli_command("test"), cwd=tmp_path, capture_output=True, text=True,
                            env=dict(environment(), PYTEST_ADDOPTS="-k 'not left_out'"),
                            timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    junit = tmp_path / "build" / "argv" / "test_results" / "argv" / "pytest.xml"
    assert read_junit(junit).counts == Counts(tests=1)
    # --pytest-args come last: they win over the user's PYTEST_ADDOPTS
    result = subprocess.run(cli_command("test", "--pytest-args", "-k", "left_out"), cwd=tmp_path,
                            capture_output=True, text=True,
                            env=dict(environment(), PYTEST_ADDOPTS="-k 'not left_out'"),
                            timeout=300)
    assert result.returncode == 1, result.stdout + result.stderr
    assert read_junit(junit).counts == Counts(tests=1, failures=1)


def test_retest_options_exclude_each_other(tested: Tested) -> None:
    root, _ = tested
    result = cli("test", "--retest-until-fail", "1", "--retest-until-pass", "1", cwd=root)
    assert result.returncode == 2
    assert "not allowed with argument" in result.stderr


def test_a_package_that_was_not_built_points_to_wsbuild_build(
        make_workspace: Callable[..., Path]) -> None:
    root = make_workspace({"fresh": ("ament_python", [])})
    result = cli("test", cwd=root)
    assert result.returncode == 2
    assert result.stderr.strip() == \
        "wsbuild: error: not built: fresh (build first: wsbuild build --packages-up-to fresh)"
    nothing = cli("test-result", cwd=root)
    assert nothing.returncode == 2
    assert "no test results" in nothing.stderr and "run wsbuild test first" in nothing.stderr


def _process_state(pid: int) -> str | None:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return None
    return next(line.split()[1] for line in status.splitlines() if line.startswith("State:"))


def test_ctrl_c_stops_the_tests_and_exits_130(tmp_path: Path) -> None:
    marker = tmp_path / "running"
    _tests(write_package(tmp_path / "src", "slow"), "test_slow.py",
           "import os, time\n\n"
           "def test_takes_forever():\n"
           f"    open({str(marker)!r}, 'w').write(str(os.getpid()))\n"
           "    time.sleep(60)\n")
    built = run_wsbuild("build", cwd=tmp_path)
    assert built.returncode == 0, built.stdout + built.stderr
    process = subprocess.Popen(cli_command("test"), cwd=tmp_path, env=environment(),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=sigint_at_default)
    try:
        deadline = time.monotonic() + 60
        while not (marker.exists() and marker.read_text()) and time.monotonic() < deadline:
            assert process.poll() is None, process.communicate()
            time.sleep(0.05)
        pytest_pid = int(marker.read_text())
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 130, out + err
    assert "  1 package aborted: slow" in out.splitlines()
    assert _process_state(pytest_pid) in (None, "Z")  # gone, at most not yet reaped


LEAVES_PROCESSES = """cmake_minimum_required(VERSION 3.14)
project(leaver NONE)
enable_testing()
# nodes its test started and never stopped (their output elsewhere, as launch has it)
add_test(NAME leaves_a_node COMMAND sh -c
         "sleep @QUIET@ >/dev/null 2>&1 & sleep @HOLDING@ >/dev/null 2>&1 & exit @EXIT@")
install(FILES package.xml DESTINATION share/leaver)
"""


@pytest.mark.parametrize("verdict", ["passing", "failing"])
def test_what_a_test_leaves_running_is_stopped_and_named(tmp_path: Path, verdict: str) -> None:
    """A test that starts processes and ends without stopping them (ROS nodes a test
    launched): when its step ends, pass or fail, every process of its session is gone, and
    the summary names what was stopped."""
    quiet, holding = f"300.{os.getpid()}1", f"300.{os.getpid()}2"
    cmake = (LEAVES_PROCESSES.replace("@QUIET@", quiet).replace("@HOLDING@", holding)
             .replace("@EXIT@", "0" if verdict == "passing" else "1"))
    (write_package(tmp_path / "src", "leaver", "cmake") / "CMakeLists.txt").write_text(cmake)
    built = run_wsbuild("build", cwd=tmp_path)
    assert built.returncode == 0, built.stdout + built.stderr
    try:
        result = cli("test", cwd=tmp_path, timeout=120)
        left = [pattern for pattern in (quiet, holding)
                if subprocess.run(["pgrep", "-f", f"sleep {pattern}"]).returncode == 0]
    finally:  # only ever ours: the durations are unique
        found = subprocess.run(["pgrep", "-f", f"sleep 300.{os.getpid()}"],
                               capture_output=True, text=True)
        for pid in found.stdout.split():
            os.kill(int(pid), signal.SIGKILL)
    assert result.returncode == (0 if verdict == "passing" else 1), result.stdout + result.stderr
    assert left == [], f"left running after wsbuild test: {left}"
    [line] = [line for line in lines(result) if "its tests left running" in line]
    assert line.startswith("  leaver: stopped 2 processes its tests left running: sleep ("), line


EDITED_TEST = """cmake_minimum_required(VERSION 3.14)
project(edited C)
enable_testing()
add_executable(test_answer test/test_answer.c)
add_test(NAME answer COMMAND test_answer)
install(FILES package.xml DESTINATION share/edited)
"""


def test_a_test_edited_since_the_build_is_named_or_built_first_with_build(
        tmp_path: Path) -> None:
    """A C test edited after the build: `wsbuild test` runs the binary that was built and
    says in one line that the package changed since it was built; `--build` builds it first,
    so the edited test runs."""
    package = write_package(tmp_path / "src", "edited", "cmake")
    (package / "CMakeLists.txt").write_text(EDITED_TEST)
    source = package / "test" / "test_answer.c"
    source.parent.mkdir()
    source.write_text("int main(void) { return 42 == 42 ? 0 : 1; }\n")
    built = run_wsbuild("build", cwd=tmp_path)
    assert built.returncode == 0, built.stdout + built.stderr
    source.write_text("int main(void) { return 42 == 43 ? 0 : 1; }\n")  # now it fails

    stale = cli("test", cwd=tmp_path)
    assert stale.returncode == 0, stale.stdout + stale.stderr  # the old binary passes
    assert stale.stderr.splitlines()[0] == (
        "wsbuild: warning: edited changed since it was built (source changed: "
        "test/test_answer.c): its tests run what was built; run `wsbuild build` first, or "
        "`wsbuild test --build`"), stale.stderr
    fresh = cli("test", "--build", cwd=tmp_path)
    assert fresh.returncode == 1, fresh.stdout + fresh.stderr  # the edited test ran
    assert "building edited first: changed since it was built (--build)" in fresh.stdout
    again = cli("test", cwd=tmp_path)
    assert "changed since it was built" not in again.stderr, again.stderr


# ------------------------------------------------------------------------------------ ROS

AMENT_PYTEST_XML = """<?xml version="1.0"?>
<package format="3">
  <name>amc</name>
  <version>0.1.0</version>
  <description>ament_cmake package with pytest and plain CTest tests</description>
  <maintainer email="dev@example.com">Dev</maintainer>
  <license>Apache-2.0</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <test_depend>ament_cmake_pytest</test_depend>
  <export><build_type>ament_cmake</build_type></export>
</package>
"""

AMENT_PYTEST_CMAKELISTS = """cmake_minimum_required(VERSION 3.14)
project(amc NONE)
find_package(ament_cmake REQUIRED)
if(BUILD_TESTING)
  find_package(ament_cmake_pytest REQUIRED)
  ament_add_pytest_test(checks test/test_checks.py)
  add_test(NAME plain_fail COMMAND sh -c "echo plain test broke; exit 1")
endif()
ament_package()
"""


@pytest.fixture(scope="module")
def ros_ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """sample_ws's packages with tests (and what they need), plus an ament_cmake package whose
    ament_add_pytest_test fails, built once."""
    root = tmp_path_factory.mktemp("ros_ws")
    shutil.copytree(SAMPLE_WS / "src", root / "src",
                    ignore=shutil.ignore_patterns("__pycache__", ".pytest_cache"))
    amc = root / "src" / "amc"
    (amc / "test").mkdir(parents=True)
    (amc / "package.xml").write_text(AMENT_PYTEST_XML)
    (amc / "CMakeLists.txt").write_text(AMENT_PYTEST_CMAKELISTS)
    (amc / "test" / "test_checks.py").write_text(
        "def test_passes():\n    assert True\n\ndef test_fails():\n    assert 'a' == 'b'\n")
    built = run_wsbuild("build", "--packages-up-to", "demo_cpp_lib", "demo_nodes_py", "amc",
                        cwd=root, env=environment())
    assert built.returncode == 0, built.stdout + built.stderr
    return root


needs_ros = pytest.mark.skipif(UNDERLAY is None, reason="the running venv has no ROS underlay")


@pytest.mark.ros
@pytest.mark.slow
@needs_ros
def test_sample_ws_tests_pass(ros_ws: Path) -> None:
    result = cli("test", "--packages-up-to", "demo_cpp_lib", "demo_nodes_py",
                 "--test-result-base", "sample_results", cwd=ros_ws)
    assert result.returncode == 0, result.stdout + result.stderr
    out = lines(result)
    assert "  2 packages passed: demo_cpp_lib demo_nodes_py" in out
    summary = next(line for line in out if line.startswith("Summary:"))
    tests = int(re.match(r"Summary: 4 packages tested, (\d+) tests, 0 errors, 0 failures, "
                         r"0 skipped", summary)[1])
    gtest = read_junit(ros_ws / "build/demo_cpp_lib/test_results/demo_cpp_lib/"
                               "test_joint_limits.gtest.xml")
    assert gtest.counts.tests >= 1 and not gtest.counts.failed
    results = ros_ws / "sample_results"
    # each gtest case is counted once: no CTest entry duplicates them
    assert sorted(p.name for p in (results / "demo_cpp_lib").iterdir()) == \
        ["test_joint_limits.gtest.xml"]
    shown = cli("test-result", "--test-result-base", "sample_results", cwd=ros_ws)
    assert (shown.returncode, lines(shown)) == \
        (0, [f"Summary: {tests} tests, 0 errors, 0 failures, 0 skipped"])


@pytest.mark.ros
@pytest.mark.slow
@needs_ros
def test_a_failing_ament_test_is_reported_by_its_own_name(ros_ws: Path) -> None:
    result = cli("test", "--packages-select", "amc", cwd=ros_ws)
    assert result.returncode == 1, result.stdout + result.stderr
    out = lines(result)
    assert any(re.fullmatch(r"Summary: 1 package tested, 3 tests, 0 errors, 2 failures, "
                            r"0 skipped \[.*\]", line) for line in out), out
    assert "    FAILED amc.plain_fail - Failed: plain test broke" in out
    assert any(line.startswith("    FAILED amc.") and
               line.endswith("test_checks.test_fails - AssertionError: assert 'a' == 'b'")
               for line in out), out
    results = ros_ws / "build" / "amc" / "test_results" / "amc"
    # the ament test's cases are in its own file; ctest.xml holds only the plain CTest test
    assert [c.name for c in read_junit(results / "ctest.xml").cases] == ["plain_fail"]
    assert read_junit(results / "checks.xunit.xml").counts == Counts(tests=2, failures=1)
