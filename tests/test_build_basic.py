"""`wsbuild build` end to end: real ament_python, ament_cmake and plain CMake packages, used."""

from __future__ import annotations

from pathlib import Path

import pytest

from test_build_helpers import (
    build,
    output,
    requires_ros,
    sourced,
    write,
    write_ament_python,
    write_cmake,
    wsbuild,
)

# ------------------------------------------------------------------ ament_python, with data files

DEMO_MAIN = """\
import os

from ament_index_python.packages import get_package_share_directory
from demo_helper import GREETING


def main():
    share = get_package_share_directory('demo_py')
    with open(os.path.join(share, 'config', 'params.yaml')) as handle:
        params = handle.read().strip()
    print(f'demo_py says {GREETING}; {params}')
"""

DEMO_DATA = {
    "launch/demo.launch.py": "# launch file v1\n",
    "config/params.yaml": "rate: 10\n",
    "urdf/robot.urdf": "<robot name='demo'/>\n",
}


def write_python_workspace(ws: Path) -> Path:
    """demo_py (console script, launch/config/urdf files) uses the library package demo_helper."""
    src = ws / "src"
    write_ament_python(src, "demo_helper", modules={"__init__.py": "GREETING = 'helper v1'\n"})
    write_ament_python(src, "demo_py", modules={"main.py": DEMO_MAIN}, data=DEMO_DATA,
                       scripts={"demo_hello": "demo_py.main:main"},
                       depend=["demo_helper"], exec_depend=["ament_index_python"])
    return ws


@pytest.fixture(scope="module")
def python_ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    ws = write_python_workspace(tmp_path_factory.mktemp("python") / "ws")
    build(ws)
    return ws


@requires_ros
def test_console_script_of_ament_python_package_runs_after_sourcing(python_ws: Path) -> None:
    result = sourced(python_ws, '"$WSBUILD_TEST_PYTHON" -m wsbuild run demo_py demo_hello\n'
                                "install/demo_py/lib/demo_py/demo_hello\n")
    assert result.stdout.splitlines() == ["demo_py says helper v1; rate: 10"] * 2


@requires_ros
def test_share_directory_and_data_files_are_found_through_the_ament_index(python_ws: Path) -> None:
    script = ("python3 -c 'from ament_index_python.packages import get_package_share_directory;"
              " print(get_package_share_directory(\"demo_py\"))'\n")
    share = Path(sourced(python_ws, script).stdout.strip())
    assert share == python_ws / "install" / "demo_py" / "share" / "demo_py"
    for rel, text in DEMO_DATA.items():
        assert (share / rel).read_text() == text
    assert (share / "package.xml").is_file()


@requires_ros
def test_wsbuild_run_works_without_sourcing(python_ws: Path) -> None:
    result = wsbuild("run", "demo_py", "demo_hello", cwd=python_ws / "src")
    assert result.returncode == 0, output(result)
    assert result.stdout.strip() == "demo_py says helper v1; rate: 10"


# ------------------------------------------------------------ ament_cmake library and its user

MYLIB_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(mylib CXX)
find_package(ament_cmake REQUIRED)
add_library(mylib SHARED src/mylib.cpp)
target_include_directories(mylib PUBLIC
  $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:include>)
install(DIRECTORY include/ DESTINATION include)
install(TARGETS mylib EXPORT export_mylib
  LIBRARY DESTINATION lib ARCHIVE DESTINATION lib RUNTIME DESTINATION bin)
ament_export_targets(export_mylib HAS_LIBRARY_TARGET)
ament_package()
"""

MYAPP_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(myapp CXX)
find_package(ament_cmake REQUIRED)
find_package(mylib REQUIRED)
add_executable(myapp src/main.cpp)
target_link_libraries(myapp mylib::mylib)
install(TARGETS myapp DESTINATION lib/${PROJECT_NAME})
ament_package()
"""


def write_cpp_workspace(ws: Path) -> Path:
    src = ws / "src"
    write_cmake(src, "mylib", MYLIB_CMAKE, build_type="ament_cmake", buildtool=["ament_cmake"],
                files={"include/mylib/mylib.hpp": "#pragma once\nint mylib_answer();\n",
                       "src/mylib.cpp": '#include "mylib/mylib.hpp"\n'
                                        "int mylib_answer() { return 42; }\n"})
    write_cmake(src, "myapp", MYAPP_CMAKE, build_type="ament_cmake", buildtool=["ament_cmake"],
                depend=["mylib"],
                files={"src/main.cpp": '#include <cstdio>\n#include "mylib/mylib.hpp"\n'
                                       'int main() { std::printf("answer %d\\n", mylib_answer());'
                                       " return 0; }\n"})
    return ws


@pytest.fixture(scope="module")
def cpp_ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    ws = write_cpp_workspace(tmp_path_factory.mktemp("cpp") / "ws")
    build(ws)
    return ws


@requires_ros
def test_app_linking_a_workspace_library_runs_after_sourcing(cpp_ws: Path) -> None:
    result = sourced(cpp_ws, f"cd /\n'{cpp_ws}/install/myapp/lib/myapp/myapp'\n")
    assert result.stdout.strip() == "answer 42"
    assert (cpp_ws / "install" / "mylib" / "lib" / "libmylib.so").is_file()
    assert (cpp_ws / "install" / "mylib" / "include" / "mylib" / "mylib.hpp").is_file()


@requires_ros
def test_wsbuild_run_finds_the_library_without_sourcing(cpp_ws: Path) -> None:
    result = wsbuild("run", "myapp", "myapp", cwd=cpp_ws)
    assert result.returncode == 0, output(result)
    assert result.stdout.strip() == "answer 42"


# ------------------------------------------------------------------------- plain CMake packages

DATA_ONLY_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(plain_xml NONE)
install(FILES data.txt DESTINATION share/${PROJECT_NAME})
"""

PLAINLIB_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(plainlib NONE)
install(FILES plainlibConfig.cmake DESTINATION share/plainlib/cmake)
"""

PLAINAPP_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(plainapp NONE)
find_package(plainlib REQUIRED)
file(WRITE ${CMAKE_BINARY_DIR}/greeting.txt "${PLAINLIB_GREETING}\\n")
install(FILES ${CMAKE_BINARY_DIR}/greeting.txt DESTINATION share/${PROJECT_NAME})
"""


@pytest.fixture(scope="module")
def cmake_ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    ws = tmp_path_factory.mktemp("cmake") / "ws"
    src = ws / "src"
    # with a package.xml, but its CMakeLists.txt installs neither package.xml nor the marker
    write_cmake(src, "plain_xml", DATA_ONLY_CMAKE, files={"data.txt": "plain data\n"})
    # without package.xml: named by project(), ordered by find_package()
    write_cmake(src, "plainlib", PLAINLIB_CMAKE, build_type=None,
                files={"plainlibConfig.cmake": 'set(PLAINLIB_GREETING "hello from plainlib")\n'})
    write_cmake(src, "plainapp", PLAINAPP_CMAKE, build_type=None)
    build(ws)
    return ws


def test_cmake_package_with_manifest_gets_package_xml_and_index_marker(cmake_ws: Path) -> None:
    prefix = cmake_ws / "install" / "plain_xml"
    assert (prefix / "share" / "plain_xml" / "data.txt").read_text() == "plain data\n"
    assert (prefix / "share" / "plain_xml" / "package.xml").read_text() == \
        (cmake_ws / "src" / "plain_xml" / "package.xml").read_text()
    index = prefix / "share" / "ament_index" / "resource_index" / "packages"
    assert (index / "plain_xml").is_file()


@requires_ros
def test_cmake_package_with_manifest_is_found_by_get_package_share_directory(
        cmake_ws: Path) -> None:
    script = ("python3 -c 'from ament_index_python.packages import get_package_share_directory;"
              " print(get_package_share_directory(\"plain_xml\"))'\n")
    share = Path(sourced(cmake_ws, script).stdout.strip())
    assert share == cmake_ws / "install" / "plain_xml" / "share" / "plain_xml"


def test_cmake_project_without_manifest_is_built_after_what_it_finds(cmake_ws: Path) -> None:
    greeting = cmake_ws / "install" / "plainapp" / "share" / "plainapp" / "greeting.txt"
    assert greeting.read_text() == "hello from plainlib\n"
    result = wsbuild("list", "-t", "-n", cwd=cmake_ws)
    assert result.returncode == 0, output(result)
    names = result.stdout.split()
    assert sorted(names) == ["plain_xml", "plainapp", "plainlib"]
    assert names.index("plainlib") < names.index("plainapp")


# ------------------------------------------------------------------- rebuilds remove stale files

STALE_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(stale_cmake NONE)
install(FILES {files} DESTINATION share/${{PROJECT_NAME}})
"""


@pytest.mark.parametrize("layout", ["isolated", "merged"])
def test_files_a_package_no_longer_installs_are_removed(tmp_path: Path, layout: str) -> None:
    ws = tmp_path / "ws"
    src = ws / "src"
    write_cmake(src, "stale_cmake", STALE_CMAKE.format(files="keep.txt drop.txt"),
                files={"keep.txt": "keep\n", "drop.txt": "drop\n"})
    write_ament_python(src, "stale_py", modules={"old_module.py": "X = 1\n"},
                       data={"config/keep.yaml": "a: 1\n", "config/drop.yaml": "b: 2\n"})
    args = ["--merge-install"] if layout == "merged" else []
    build(ws, *args)

    def prefix(name: str) -> Path:
        return ws / "install" if layout == "merged" else ws / "install" / name

    cmake_share = prefix("stale_cmake") / "share" / "stale_cmake"
    py_share = prefix("stale_py") / "share" / "stale_py"
    old_modules = list(prefix("stale_py").glob("lib/python3*/site-packages/stale_py/old_module.py"))
    assert (cmake_share / "drop.txt").is_file() and (py_share / "config" / "drop.yaml").is_file()
    assert len(old_modules) == 1

    write(src / "stale_cmake" / "CMakeLists.txt", STALE_CMAKE.format(files="keep.txt"))
    (src / "stale_py" / "config" / "drop.yaml").unlink()
    (src / "stale_py" / "stale_py" / "old_module.py").unlink()
    build(ws, *args)

    assert (cmake_share / "keep.txt").read_text() == "keep\n"
    assert not (cmake_share / "drop.txt").exists()
    assert (py_share / "config" / "keep.yaml").read_text() == "a: 1\n"
    assert not (py_share / "config" / "drop.yaml").exists()
    assert not old_modules[0].exists()


# ----------------------------------------------------------------------------------------- logs

def test_each_package_has_its_command_and_output_log(cmake_ws: Path) -> None:
    latest = cmake_ws / "log" / "latest_build"
    assert latest.is_symlink()
    assert (cmake_ws / "log" / "latest").resolve() == latest.resolve()
    for name in ("plain_xml", "plainlib", "plainapp"):
        command_log = latest / name / "command.log"
        assert "cmake" in command_log.read_text()
        assert (latest / name / "stdout_stderr.log").is_file()
    assert "-- Configuring done" in (latest / "plainapp" / "stdout_stderr.log").read_text()


def _one_package_ws(root: Path) -> Path:
    write_cmake(root / "src", "solo", "cmake_minimum_required(VERSION 3.14)\nproject(solo NONE)\n")
    return root


def test_only_the_last_ten_runs_are_kept(tmp_path: Path) -> None:
    ws = _one_package_ws(tmp_path / "ws")
    log = ws / "log"
    old = [log / f"build_2020-01-01_00-00-{second:02d}" for second in range(10)]
    for run in old:
        (run / "solo").mkdir(parents=True)
    build(ws)
    build(ws)
    runs = sorted(p.name for p in log.iterdir() if p.is_dir() and not p.is_symlink())
    assert len(runs) == 10
    assert runs[:8] == [p.name for p in old[2:]]
    newest = runs[-1]
    assert (log / "latest_build").resolve() == (log / newest).resolve()
    # the second build had nothing to do: the run's log says so instead of a package log
    assert "solo: up to date" in (log / "latest" / "up_to_date.log").read_text()


def test_only_the_last_ten_runs_are_kept_when_runs_share_a_second(tmp_path: Path) -> None:
    """Fast scripted builds start several runs in one second: log/build_<stamp>_<n>."""
    ws = _one_package_ws(tmp_path / "ws")
    log = ws / "log"
    stamp = "build_2020-01-01_00-00-00"
    old = [log / (stamp if n == 0 else f"{stamp}_{n}") for n in range(12)]
    for run in old:
        (run / "solo").mkdir(parents=True)
    build(ws)
    kept = {p.name for p in log.iterdir() if p.is_dir() and not p.is_symlink()}
    assert len(kept) == 10
    # the nine newest of the earlier runs survive, the three oldest go
    assert {p.name for p in old[3:]} <= kept, sorted(kept)


# ------------------------------------------------------ plain CMake C library and its user

CLIB_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(clib C)
add_library(clib SHARED clib.c)
target_include_directories(clib PUBLIC
  $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}> $<INSTALL_INTERFACE:include>)
install(FILES clib.h DESTINATION include)
install(TARGETS clib EXPORT clibTargets LIBRARY DESTINATION lib)
install(EXPORT clibTargets NAMESPACE clib:: DESTINATION lib/cmake/clib FILE clibConfig.cmake)
"""

CAPP_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(capp C)
find_package(clib REQUIRED)
add_executable(capp main.c)
target_link_libraries(capp clib::clib)
install(TARGETS capp RUNTIME DESTINATION bin)
"""


@pytest.mark.parametrize("options", [
    (),
    ("--merge-install",),
    ("--symlink-install",),
    ("--merge-install", "--symlink-install"),
], ids=["isolated", "merged", "isolated-symlink", "merged-symlink"])
def test_plain_cmake_program_and_library_work_after_sourcing(tmp_path: Path,
                                                             options: tuple[str, ...]) -> None:
    """The hooks put bin/ on PATH and lib/ on LD_LIBRARY_PATH (CMake installs no RPATH)."""
    ws = tmp_path / "ws"
    src = ws / "src"
    write_cmake(src, "clib", CLIB_CMAKE,
                files={"clib.h": "int clib_value(void);\n",
                       "clib.c": '#include "clib.h"\nint clib_value(void) { return 7; }\n'})
    write_cmake(src, "capp", CAPP_CMAKE, depend=["clib"],
                files={"main.c": '#include <stdio.h>\n#include "clib.h"\n'
                                 'int main(void) { printf("clib %d\\n", clib_value());'
                                 " return 0; }\n"})
    build(ws, *options)
    result = sourced(ws, "cd /\ncapp\n")
    assert result.stdout.strip() == "clib 7"
