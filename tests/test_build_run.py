"""`wsbuild run PKG EXECUTABLE` on a built workspace: arguments, exit codes, and its errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from test_build_helpers import build, clean_env, output, write_ament_python, write_cmake
from test_build_helpers import wsbuild

ECHO_MAIN = """\
import sys


def main():
    print('args:', ' '.join(sys.argv[1:]))
    return int(sys.argv[-1]) if sys.argv[-1].isdigit() else 0
"""


@pytest.fixture(scope="module")
def run_ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    ws = tmp_path_factory.mktemp("run") / "ws"
    src = ws / "src"
    write_ament_python(src, "runner_py", modules={"main.py": ECHO_MAIN},
                       scripts={"echo_args": "runner_py.main:main",
                                "echo_other": "runner_py.main:main"},
                       data={"launch/talk.launch.py": "def generate_launch_description():\n"
                                                      "    pass\n"})
    write_cmake(src, "no_exes", "cmake_minimum_required(VERSION 3.14)\nproject(no_exes NONE)\n")
    build(ws)
    return ws


def _error(result) -> str:  # type: ignore[no-untyped-def]
    errors = [line for line in result.stderr.splitlines() if line.startswith("wsbuild: error:")]
    assert len(errors) == 1, output(result)
    return errors[0]


def test_arguments_and_exit_code_pass_through(run_ws: Path) -> None:
    result = wsbuild("run", "runner_py", "echo_args", "--ros-args", "-p", "rate:=2.0", "3",
                     cwd=run_ws)
    assert result.returncode == 3, output(result)
    assert result.stdout.strip() == "args: --ros-args -p rate:=2.0 3"


def test_unknown_package_with_a_close_name_is_suggested(run_ws: Path) -> None:
    result = wsbuild("run", "runner_pi", "echo_args", cwd=run_ws)
    assert result.returncode == 2, output(result)
    error = _error(result)
    assert "runner_pi" in error and "'runner_py'" in error


def test_unknown_package_lists_the_packages_with_executables(run_ws: Path) -> None:
    result = wsbuild("run", "zzz", "echo_args", cwd=run_ws)
    assert result.returncode == 2, output(result)
    error = _error(result)
    assert "'zzz' not found" in error
    assert "runner_py" in error
    assert "no_exes" not in error


def test_unknown_executable_lists_the_package_executables(run_ws: Path) -> None:
    result = wsbuild("run", "runner_py", "talker", cwd=run_ws)
    assert result.returncode == 2, output(result)
    error = _error(result)
    assert "no executable 'talker' in package 'runner_py'" in error
    assert "echo_args" in error and "echo_other" in error


def test_run_with_a_package_alone_lists_its_executables(run_ws: Path) -> None:
    """`wsbuild run PKG` (no executable): what it can run, not argparse's complaint."""
    result = wsbuild("run", "runner_py", cwd=run_ws)
    assert result.returncode == 0, output(result)
    assert result.stdout.splitlines()[0] == \
        "executables of runner_py (wsbuild run runner_py EXECUTABLE):"
    assert "  echo_args" in result.stdout.splitlines()
    assert "required" not in result.stderr
    empty = wsbuild("run", "no_exes", cwd=run_ws)
    assert empty.returncode == 2 and "no_exes installs no executables" in _error(empty)


def test_package_without_executables_says_so(run_ws: Path) -> None:
    result = wsbuild("run", "no_exes", "anything", cwd=run_ws)
    assert result.returncode == 2, output(result)
    assert "no_exes installs no executables" in _error(result)


def test_run_before_building_says_to_build(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_ament_python(ws / "src", "unbuilt", modules={"main.py": ECHO_MAIN},
                       scripts={"go": "unbuilt.main:main"})
    result = wsbuild("run", "unbuilt", "go", cwd=ws)
    assert result.returncode == 2, output(result)
    assert "wsbuild build" in _error(result)


def test_a_launch_file_is_recognised_and_ros2_launch_is_named_with_where_it_comes_from(
        run_ws: Path, tmp_path: Path) -> None:
    result = wsbuild("run", "runner_py", "talk.launch.py", cwd=run_ws)
    assert result.returncode == 2, output(result)
    error = _error(result)
    installed = run_ws / "install/runner_py/share/runner_py/launch/talk.launch.py"
    assert f"'talk.launch.py' is a launch file ({installed}), not an executable" in error
    assert "run it with `ros2 launch runner_py talk.launch.py`" in error
    # no wheel carries ros2launch: it comes from source
    assert "<exec_depend>ros2launch</exec_depend>" in error
    assert "wsbuild deps install --from-source" in error

    ros2launch = tmp_path / "prefix"  # an underlay that has it
    (ros2launch / "share/ament_index/resource_index/packages").mkdir(parents=True)
    (ros2launch / "share/ament_index/resource_index/packages/ros2launch").touch()
    env = clean_env(AMENT_PREFIX_PATH=str(ros2launch))
    result = wsbuild("run", "runner_py", "talk.launch.py", cwd=run_ws, env=env)
    assert "(run it with: ros2 launch runner_py talk.launch.py  (in a shell that sourced " \
        "install/setup.bash))" in _error(result)
    result = wsbuild("run", "runner_py", "walk.launch.xml", cwd=run_ws)
    assert "none by that name (its launch files: talk.launch.py)" in _error(result)


def test_a_launch_file_of_a_package_that_declares_ros2launch_says_what_is_true(
        tmp_path: Path) -> None:
    """`pkg create --launch` declared ros2launch: the error says it is declared, has no
    wheel, and where it comes from online and offline, not to declare it."""
    ws = tmp_path / "ws"
    (ws / "src").mkdir(parents=True)
    created = wsbuild("pkg", "create", "launcher", "--build-type", "ament_python",
                      "--node-name", "talker", "--launch", cwd=ws)
    assert created.returncode == 0, output(created)
    assert wsbuild("build", cwd=ws).returncode == 0
    launch = next(p.name for p in (ws / "install/launcher/share/launcher").rglob("*launch*")
                  if p.is_file())
    error = _error(wsbuild("run", "launcher", launch, cwd=ws))
    assert "launcher declares it (<exec_depend>ros2launch</exec_depend>), but it has no PyPI " \
        "wheel; `wsbuild deps install --from-source` fetches it" in error, error
    assert "offline, install it with ROS 2 (apt install ros-jazzy-ros2launch)" in error
    assert "declare <exec_depend>" not in error
