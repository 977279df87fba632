"""The corpus (tests/data/corpus, described in tests/README.md): the patterns of real ROS 2
repositories, built by wsbuild with no flags and by colcon, the oracle.

wsbuild keeps BUILD_TESTING at its default (on), as a colcon user's first build does; colcon
needs -DBUILD_TESTING=OFF on this underlay, because no wheel provides ament_lint_auto (wsbuild
stands in for it, underlay/lint.py). The installs are compared file by file, apart from
INTENTIONAL_DIFFERENCES, and then used: the ament index, console scripts, a C++ executable on the
export chain and the generated interfaces work from wsbuild's install, and `wsbuild test` runs
every package's tests: the installed linters for real, upstream's test_copyright.py (whose
linter no distribution provides) counted as skipped, launch-style tests through a test
dependency's pytest plugin.
"""

from __future__ import annotations

import fnmatch
import json
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from test_build_helpers import (
    REQUIRES_ROS,
    clean_env,
    output,
    ros_underlay,
    sourced,
    wsbuild,
)
from wsbuild.underlay.environment import build_environment

# the module's fixtures build once: its tests share one xdist worker
pytestmark = [*REQUIRES_ROS, pytest.mark.slow, pytest.mark.xdist_group("corpus")]

CORPUS = Path(__file__).parent / "data" / "corpus" / "src"
PACKAGES = sorted(p.name for p in CORPUS.iterdir() if (p / "package.xml").is_file())

#: what colcon installs and wsbuild does not, on purpose (README: "How it differs from colcon")
INTENTIONAL_DIFFERENCES = {
    "*.ps1": "PowerShell scripts: wsbuild writes sh, bash and zsh ones",
    "_local_setup_util_ps1.py": "colcon's Python helper for local_setup.ps1",
    "_local_setup_util_sh.py": "colcon's Python helper that orders the packages when "
                               "local_setup.sh is sourced: wsbuild writes that order statically",
}


def _copy_corpus(root: Path) -> Path:
    shutil.copytree(CORPUS, root / "src")
    return root


def _files(install: Path) -> set[str]:
    found = set()
    for dirpath, dirnames, filenames in os.walk(install):
        for name in filenames + [d for d in dirnames if os.path.islink(os.path.join(dirpath, d))]:
            found.add(os.path.relpath(os.path.join(dirpath, name), install))
    return found


def _intentional(path: str) -> bool:
    return any(fnmatch.fnmatch(os.path.basename(path), pattern)
               for pattern in INTENTIONAL_DIFFERENCES)


@pytest.fixture(scope="module")
def wsbuilt(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    """The corpus built by `wsbuild build` with no flags."""
    ws = _copy_corpus(tmp_path_factory.mktemp("corpus") / "ws")
    return ws, wsbuild("build", cwd=ws, timeout=1500)


@pytest.fixture(scope="module")
def colcon_built(colcon: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The corpus built by colcon against the ROS venv, its environment applied as a sourced
    underlay's would be."""
    ws = _copy_corpus(tmp_path_factory.mktemp("corpus_colcon") / "ws")
    ros = ros_underlay()
    assert ros is not None
    env = clean_env(COLCON_HOME=str(ws.parent / "colcon_home"))  # no user defaults or mixins
    env.update(build_environment(ros, env))
    done = subprocess.run(
        [str(colcon), "build", "--event-handlers", "console_cohesion+",
         # no ament_lint_auto wheel: colcon cannot configure the lint tests
         "--cmake-args", "-DBUILD_TESTING=OFF"],
        cwd=ws, env=env, capture_output=True, text=True, timeout=1500, check=False)
    assert done.returncode == 0, output(done)
    return ws


def test_builds_with_no_flags_warning_only_about_what_is_really_missing(
        wsbuilt: tuple[Path, subprocess.CompletedProcess[str]]) -> None:
    ws, result = wsbuilt
    assert result.returncode == 0, output(result)
    assert [p for p in PACKAGES if (ws / "install" / p / "share" / p).is_dir()] == PACKAGES
    lines = result.stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("WARNING: build dependencies"))
    # turtlesim is absent (needed at run time only); xacro is the pip distribution in the venv
    assert lines[start + 1:start + 3] == [
        "  corpus_bringup:",
        "    turtlesim: not found: `wsbuild deps install` looks for it (a wheel, a system "
        "package, its sources) and installs it",
    ]
    assert not lines[start + 3].startswith("  "), output(result)
    # the linters without a wheel are named once
    [note] = [line for line in lines if line.startswith("linters not installed")]
    for linter in ("ament_copyright", "ament_xmllint"):
        assert linter in note
    # installed: they run (lint_cmake through wsbuild's CMake function for its PyPI program)
    for linter in ("ament_cppcheck", "ament_cpplint", "ament_uncrustify", "ament_flake8",
                   "ament_lint_cmake"):
        assert linter not in note


def test_installs_the_files_colcon_installs(
        wsbuilt: tuple[Path, subprocess.CompletedProcess[str]], colcon_built: Path) -> None:
    ws, result = wsbuilt
    assert result.returncode == 0, output(result)
    ours = _files(ws / "install")
    theirs = _files(colcon_built / "install")
    only_colcon = sorted(path for path in theirs - ours if not _intentional(path))
    only_wsbuild = sorted(ours - theirs)
    assert only_colcon == [] and only_wsbuild == []
    assert any(_intentional(path) for path in theirs)  # the list is not stale
    assert len(ours) > 400


CHECKS = """\
"$WSBUILD_TEST_PYTHON" -m wsbuild run corpus_py_nodes route_planner --plan 0 0 3 4
install/corpus_py_cli/lib/corpus_py_cli/corpus_cli list
install/corpus_py_cli/lib/corpus_py_cli/corpus_cli describe corpus_app
install/corpus_launch_tools/lib/corpus_launch_tools/list_shares corpus_description
install/corpus_launch_tools/lib/corpus_launch_tools/expand_xacro.py corpus_description \\
    urdf/robot.urdf.xacro | grep -o 'joint name="[a-z_]*"'
install/corpus_app/lib/corpus_app/route_length 0 0 3 4 3 0
"$WSBUILD_TEST_PYTHON" -c 'from corpus_interfaces.action import FollowRoute
from corpus_interfaces.srv import PlanRoute
goal = FollowRoute.Goal()
goal.route.points.append(PlanRoute.Request().goal)
print(type(goal).__name__, len(goal.route.points), goal.route.speed)'
"""


def test_the_install_works_ament_index_console_scripts_imports(
        wsbuilt: tuple[Path, subprocess.CompletedProcess[str]]) -> None:
    ws, result = wsbuilt
    assert result.returncode == 0, output(result)
    lines = sourced(ws, CHECKS, cwd=ws).stdout.splitlines()
    assert lines[0] == "straight: 5 points, length 5.000"
    end = 1 + len(PACKAGES)
    assert lines[1:end] == PACKAGES  # ament_index_python, through an entry point group
    assert lines[end] == f"package corpus_app is installed in {ws / 'install' / 'corpus_app'}"
    share = ws / "install" / "corpus_description" / "share" / "corpus_description"
    assert f"corpus_description {share}" in lines
    assert 'joint name="left_wheel_joint"' in lines and 'joint name="right_wheel_joint"' in lines
    assert "9" in lines  # (0,0)-(3,4)-(3,0), the C++ executable through the three-deep export chain
    assert lines[-1] == "FollowRoute_Goal 1 0.5"


#: packages whose only files are installed, as upstream's launch and description packages
WITHOUT_TESTS = ["corpus_bringup", "corpus_description"]
#: the linters no distribution provides; upstream's Python packages import ament_copyright
NOT_INSTALLED = "  not installed, not run: ament_copyright (4 packages): counted as skipped"
#: why ament_cppcheck skips its own tests with Debian's cppcheck 2.10 (upstream's choice)
CPPCHECK_SKIP = "Test Skipped due to cppcheck 2.10 performance issues"


def _cases(ws: Path, package: str) -> dict[str, str]:
    """test case name -> outcome, from every JUnit file of a package."""
    outcome: dict[str, str] = {}
    for path in (ws / "build" / package / "test_results").rglob("*.xml"):
        for case in ET.parse(path).getroot().iter("testcase"):
            state = "passed"
            for tag in ("failure", "error", "skipped"):
                if case.find(tag) is not None:
                    state = tag
            # cppcheck.xunit.xml, test_geometry.gtest.xml, pytest.xml: the test's name
            outcome[f"{path.name.split('.')[0]}:{case.get('name')}"] = state
    return outcome


def _junit_totals(ws: Path) -> tuple[dict[str, int], set[str]]:
    """Counts by outcome over every JUnit file of the workspace, and the skip reasons."""
    totals = {"tests": 0, "errors": 0, "failures": 0, "skipped": 0}
    reasons: set[str] = set()
    for path in (ws / "build").glob("*/test_results/*/*.xml"):
        for case in ET.parse(path).getroot().iter("testcase"):
            totals["tests"] += 1
            for tag, key in (("error", "errors"), ("failure", "failures"), ("skipped", "skipped")):
                element = case.find(tag)
                if element is not None:
                    totals[key] += 1
                    text = element.get("message") or element.text or ""
                    reasons.add(CPPCHECK_SKIP if CPPCHECK_SKIP in text else text.strip())
    return totals, reasons


def test_wsbuild_test_runs_every_packages_tests_and_the_installed_linters(
        wsbuilt: tuple[Path, subprocess.CompletedProcess[str]]) -> None:
    ws, result = wsbuilt
    assert result.returncode == 0, output(result)
    tested = wsbuild("test", cwd=ws, timeout=900)
    assert tested.returncode == 0, output(tested)
    lines = tested.stdout.splitlines()
    summary = lines[next(i for i, line in enumerate(lines) if line.startswith("Summary:")):]
    with_tests = [p for p in PACKAGES if p not in WITHOUT_TESTS]
    assert summary[1:4] == [f"  {len(with_tests)} packages passed: {' '.join(with_tests)}",
                            f"  2 packages without tests: {' '.join(WITHOUT_TESTS)}",
                            NOT_INSTALLED]
    # the summary counts what the JUnit files hold, and nothing is skipped but the linter
    # that is not installed and upstream's own cppcheck skip
    totals, reasons = _junit_totals(ws)
    assert summary[0].startswith(
        f"Summary: 12 packages tested, {totals['tests']} tests, {totals['errors']} errors, "
        f"{totals['failures']} failures, {totals['skipped']} skipped [")
    assert totals["errors"] == totals["failures"] == 0
    assert reasons == {"not installed, not run: ament_copyright", CPPCHECK_SKIP}
    for package in with_tests:
        assert any(state == "passed" for state in _cases(ws, package).values()), package

    msgs = _cases(ws, "corpus_base_msgs")
    assert any(name.startswith("cpplint_rosidl_generated_c:") for name in msgs)
    assert any(name.startswith("uncrustify_rosidl_generated_cpp:") for name in msgs)
    assert any(name.startswith("flake8_rosidl_generated_py:") for name in msgs)
    lib = _cases(ws, "corpus_core_lib")
    assert lib["test_geometry:distance"] == "passed"
    assert any(name.startswith("cpplint:") for name in lib)
    assert any(name.startswith("uncrustify:") for name in lib)
    assert lib["lint_cmake:CMakeLists.txt"] == "passed"
    # ament_cppcheck declines cppcheck < 2.11 ("known performance issues") and says so
    assert any(name.startswith("cppcheck:") for name in lib)
    tools = _cases(ws, "corpus_launch_tools")
    assert {"flake8", "pep257", "test_share_file"} <= {name.split(":")[0] for name in tools}
    nodes = _cases(ws, "corpus_py_nodes")
    assert {nodes[f"pytest:{case}"] for case in ("test_flake8", "test_pep257",
                                                  "test_straight_route_has_steps_plus_one_points")} \
        == {"passed"}
    assert nodes["pytest:test_copyright"] == "skipped"
    # launch-style tests, collected by a test dependency's pytest plugin (pytest 7 hooks)
    assert _cases(ws, "corpus_launch_checks")["pytest:test_counter_launch"] == "passed"


@pytest.fixture(scope="module")
def unbuilt(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _copy_corpus(tmp_path_factory.mktemp("corpus_unbuilt") / "ws")


def test_strict_dependencies_refuses_naming_what_is_missing(unbuilt: Path) -> None:
    result = wsbuild("build", "--strict-dependencies", cwd=unbuilt)
    assert result.returncode == 2, output(result)
    assert "unresolved build dependencies: turtlesim (needed by corpus_bringup)" in result.stderr
    assert "xacro" not in result.stderr  # a pip distribution is a resolved dependency
    install = unbuilt / "install"
    assert not any(p.is_dir() for p in install.iterdir()) if install.exists() else True


def test_info_says_which_source_resolves_each_dependency(unbuilt: Path) -> None:
    result = wsbuild("info", "corpus_description", "corpus_bringup", "corpus_py_nodes",
                     "corpus_app", "--json", cwd=unbuilt)
    assert result.returncode == 0, output(result)
    found = {record["name"]: {dep["name"]: dep["resolution"] for dep in record["dependencies"]}
             for record in json.loads(result.stdout)}
    assert found["corpus_description"]["xacro"] == "python distribution"
    assert found["corpus_description"]["corpus_launch_tools"] == "workspace"
    assert found["corpus_bringup"]["turtlesim"] == "unresolved"
    assert found["corpus_py_nodes"]["rclpy"] == "ament index"
    assert found["corpus_py_nodes"]["python3-numpy"] == "python distribution"
    assert found["corpus_py_nodes"]["python3-yaml"] == "python distribution"
    # the ROS 1 branch of <depend condition="$ROS_VERSION == 1"> is not a dependency here
    assert "roscpp" not in found["corpus_app"] and "catkin" not in found["corpus_app"]
    assert found["corpus_app"]["ament_cmake"] == "ament index"


def test_the_corpus_is_what_tests_readme_describes() -> None:
    readme = (Path(__file__).parent / "README.md").read_text()
    for package in PACKAGES:
        assert f"`{package}`" in readme, package
