"""Early cutoff: a package is rebuilt because of a dependency only when something it read of
that dependency while building changed (its build system's own lists: the headers, CMake
files and libraries of a CMake build, the depfiles of its custom commands; what a setup.py
opened, stat'ed and listed, its imports included). A comment edited in a root Python package
rebuilds that package only; a header changed in a root C++ package rebuilds its C++ users; a
dependency rebuilt to the same bytes stops the wave there. In wsbuild's default configuration
(the build cache on), every build step under the build-step oracle."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from test_build_helpers import clean_env, output, write, write_ament_python, write_cmake
from test_build_helpers import wsbuild as run


#: every build step of this module's builds runs under strace, checked against the record
pytestmark = pytest.mark.usefixtures("traced_steps")


def _env() -> dict[str, str]:
    """A fresh terminal, in wsbuild's default configuration (the local build cache on)."""
    return clean_env()


def _build(ws: Path, *args: str) -> subprocess.CompletedProcess[str]:
    result = run("build", *args, cwd=ws, env=_env())
    assert result.returncode == 0, output(result)
    return result


def _rebuilt(result: subprocess.CompletedProcess[str]) -> list[str]:
    return sorted(line.split()[2] for line in result.stdout.splitlines()
                  if line.startswith("Finished <<<"))


def _cut_off(result: subprocess.CompletedProcess[str]) -> list[str]:
    for line in result.stdout.splitlines():
        if " cut off (a dependency was rebuilt" in line:
            return sorted(line.split(": ", 1)[1].split())
    return []


def _python_root_and_users(src: Path, users: int) -> Path:
    root = write_ament_python(src, "root_py", modules={"__init__.py": "# v1\nX = 1\n"})
    for i in range(users):
        write_ament_python(src, f"user_{i}", modules={},
                           depend=["root_py"] if i % 2 else (), exec_depend=["root_py"]
                           if not i % 2 else ())
    return root


def test_a_comment_in_a_root_python_package_rebuilds_that_package_only(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    root = _python_root_and_users(ws / "src", 6)
    _build(ws)
    before = {p: p.read_bytes() for p in (ws / "install").rglob("*") if p.is_file()
              and "root_py" not in str(p.relative_to(ws / "install")).split("/")[0]}

    write(root / "root_py" / "__init__.py", "# v2, a comment edited\nX = 1\n")
    result = _build(ws)

    assert _rebuilt(result) == ["root_py"], output(result)
    assert _cut_off(result) == [f"user_{i}" for i in range(6)], output(result)
    after = {p: p.read_bytes() for p in before}
    assert after == before  # the users' installs are untouched
    assert "0 packages finished" in _build(ws).stdout  # and they stay up to date


def test_a_setup_py_that_imports_its_dependency_is_rebuilt_when_that_changes(
        tmp_path: Path) -> None:
    """What a setup.py opens is its build's dependency list: one that reads its dependency's
    module is rebuilt when the module changes."""
    ws = tmp_path / "ws"
    root = write_ament_python(ws / "src", "version_source",
                              modules={"__init__.py": "VERSION = '1.0'\n"})
    reader = write_ament_python(ws / "src", "reader", modules={},
                                depend=["version_source"])
    setup = (reader / "setup.py").read_text()
    (reader / "setup.py").write_text(
        "from version_source import VERSION\n" + setup.replace("version='0.1.0'",
                                                               "version=VERSION"))
    _build(ws)
    write(root / "version_source" / "__init__.py", "VERSION = '2.0'\n")

    result = _build(ws)

    assert _rebuilt(result) == ["reader", "version_source"], output(result)
    dist = list((ws / "install" / "reader").rglob("reader-*.egg-info"))
    assert dist and "2.0" in dist[0].name, dist


CPP_LIB = """
cmake_minimum_required(VERSION 3.16)
project(libroot CXX)
add_library(libroot SHARED src/root.cpp)
target_include_directories(libroot PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                          $<INSTALL_INTERFACE:include>)
install(TARGETS libroot EXPORT librootTargets LIBRARY DESTINATION lib)
install(DIRECTORY include/ DESTINATION include)
install(EXPORT librootTargets FILE librootConfig.cmake DESTINATION share/libroot/cmake)
install(FILES package.xml DESTINATION share/libroot)
"""

CPP_USER = """
cmake_minimum_required(VERSION 3.16)
project({name} CXX)
find_package(libroot REQUIRED)
add_executable({name} main.cpp)
target_link_libraries({name} libroot)
install(TARGETS {name} DESTINATION bin)
install(FILES package.xml DESTINATION share/{name})
"""


def _cpp_workspace(ws: Path) -> None:
    write_cmake(ws / "src", "libroot", CPP_LIB, files={
        "include/libroot/root.hpp": "#pragma once\n#define ROOT_SCALE 2\nint root(int);\n",
        "src/root.cpp": '#include "libroot/root.hpp"\nint root(int x) { return x * ROOT_SCALE; }\n'})
    for name in ("app_a", "app_b"):
        write_cmake(ws / "src", name, CPP_USER.format(name=name), depend=["libroot"], files={
            "main.cpp": '#include <cstdio>\n#include "libroot/root.hpp"\n'
                        'int main() { std::printf("%d %d\\n", root(21), ROOT_SCALE); }\n'})


def _run(ws: Path, name: str) -> str:
    env = _env()
    env["LD_LIBRARY_PATH"] = str(ws / "install" / "libroot" / "lib")
    return subprocess.run([str(ws / "install" / name / "bin" / name)], env=env,
                          capture_output=True, text=True, check=True).stdout.strip()


def test_a_header_changed_in_a_root_cpp_package_rebuilds_its_users(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _cpp_workspace(ws)
    _build(ws)
    assert _run(ws, "app_a") == "42 2"
    header = ws / "src" / "libroot" / "include" / "libroot" / "root.hpp"
    header.write_text(header.read_text().replace("ROOT_SCALE 2", "ROOT_SCALE 3"))

    result = _build(ws)

    assert _rebuilt(result) == ["app_a", "app_b", "libroot"], output(result)
    assert _run(ws, "app_a") == "63 3" and _run(ws, "app_b") == "63 3"


def test_a_dependency_rebuilt_to_the_same_bytes_rebuilds_nothing_downstream(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _cpp_workspace(ws)
    _build(ws)
    source = ws / "src" / "libroot" / "src" / "root.cpp"
    source.write_text(source.read_text() + "// only a comment\n")

    result = _build(ws)

    assert _rebuilt(result) == ["libroot"], output(result)
    assert _cut_off(result) == ["app_a", "app_b"], output(result)
    assert _run(ws, "app_b") == "42 2"


def test_the_dry_run_says_why_a_package_whose_dependency_was_rebuilt_is_up_to_date(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    root = _python_root_and_users(ws / "src", 2)
    _build(ws)
    write(root / "root_py" / "__init__.py", "# edited\nX = 1\n")
    _build(ws, "--packages-select", "root_py")

    dry = run("build", "--dry-run", "--json", cwd=ws, env=_env())

    assert dry.returncode == 0, output(dry)
    plan = {p["name"]: p for p in json.loads(dry.stdout)["packages"]}
    assert plan["user_0"]["decision"] == "up to date"
    assert plan["user_0"]["note"] == ("dependency root_py rebuilt; nothing this package "
                                      "builds from changed → up to date")
    text = run("build", "--dry-run", cwd=ws, env=_env()).stdout
    assert "user_1" in text and "nothing this package builds from changed" in text


def test_the_report_page_says_which_packages_were_cut_off(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _cpp_workspace(ws)
    _build(ws)
    source = ws / "src" / "libroot" / "src" / "root.cpp"
    source.write_text(source.read_text() + "// a comment\n")
    _build(ws)

    record = json.loads((ws / "log" / "latest_build" / "report.json").read_text())
    outcomes = {p["name"]: (p["outcome"], p["message"]) for p in record["packages"]}
    assert outcomes["app_a"] == ("up to date", "dependency libroot rebuilt; nothing this "
                                 "package builds from changed → up to date")
    page = (ws / "log" / "latest_build" / "report.html").read_text()
    assert page.count("nothing this package builds from changed") >= 2  # app_a, app_b rows


VALUES_LIB = """
cmake_minimum_required(VERSION 3.16)
project(libvals NONE)
install(DIRECTORY include/ DESTINATION include)
install(FILES package.xml DESTINATION share/libvals)
"""

TABLE_USER = """
cmake_minimum_required(VERSION 3.16)
project(tabler CXX)
find_path(VALUES_DIR libvals/values.h REQUIRED)
add_custom_command(
  OUTPUT table.h
  COMMAND ${CMAKE_COMMAND} -DOUT=table.h -DDEP=table.d -DSRC=${VALUES_DIR}/libvals/values.h
          -P ${CMAKE_CURRENT_SOURCE_DIR}/gen.cmake
  DEPFILE table.d)
add_executable(tabler main.cpp table.h)
target_include_directories(tabler PRIVATE ${CMAKE_CURRENT_BINARY_DIR})
install(TARGETS tabler DESTINATION bin)
install(FILES package.xml DESTINATION share/tabler)
"""

GEN_TABLE = """
file(STRINGS "${SRC}" lines REGEX "^#define")
string(REPLACE "#define VALUE" "#define TABLE_VALUE" table "${lines}")
file(WRITE "${OUT}" "${table}\\n")
file(WRITE "${DEP}" "table.h: ${SRC}\\n")
"""


def test_a_dependents_table_generated_from_a_dependencys_header_follows_it(
        tmp_path: Path) -> None:
    """A custom command reads the dependency's installed header and names it in its depfile
    (`add_custom_command(DEPFILE …)`: Ninja's deps log lists nothing for it): after the
    dependency is rebuilt with another value, the dependent is rebuilt, not cut off."""
    ws = tmp_path / "ws"
    lib = write_cmake(ws / "src", "libvals", VALUES_LIB,
                      files={"include/libvals/values.h": "#define VALUE 7\n"})
    write_cmake(ws / "src", "tabler", TABLE_USER, depend=["libvals"], files={
        "gen.cmake": GEN_TABLE,
        "main.cpp": '#include <cstdio>\n#include "table.h"\n'
                    'int main() { std::printf("%d\\n", TABLE_VALUE); }\n'})
    _build(ws)
    program = ws / "install" / "tabler" / "bin" / "tabler"
    assert subprocess.run([str(program)], capture_output=True, text=True).stdout == "7\n"
    write(lib / "include" / "libvals" / "values.h", "#define VALUE 8\n")

    result = _build(ws)

    assert _rebuilt(result) == ["libvals", "tabler"], output(result)
    assert subprocess.run([str(program)], capture_output=True, text=True).stdout == "8\n"


TOOLBOX = """
cmake_minimum_required(VERSION 3.16)
project(toolbox NONE)
install(DIRECTORY tools/ DESTINATION share/toolbox/tools)
install(FILES package.xml DESTINATION share/toolbox)
install(FILES resource/toolbox DESTINATION share/ament_index/resource_index/packages)
"""

TOOLKIT_SETUP = """
import os
from glob import glob

from ament_index_python.packages import get_package_share_directory
from setuptools import setup

tools = sorted(os.path.splitext(os.path.basename(path))[0] for path in
               glob(os.path.join(get_package_share_directory('toolbox'), 'tools', '*.tool')))
setup(
    name='toolkit', version='0.1.0', packages=['toolkit'],
    data_files=[('share/ament_index/resource_index/packages', ['resource/toolkit']),
                ('share/toolkit', ['package.xml'])],
    entry_points={'console_scripts': [f'{tool} = toolkit.main:main' for tool in tools]},
)
"""


def test_a_setup_py_glob_over_a_dependencys_share_directory_sees_a_new_file(
        tmp_path: Path) -> None:
    """setup.py makes a console script of each file a dependency installs into its share
    directory: the listing is in the record (the audit hook's listings), so a new file there
    rebuilds it (no early cutoff) and the script appears."""
    ws = tmp_path / "ws"
    box = write_cmake(ws / "src", "toolbox", TOOLBOX, files={"tools/hammer.tool": "",
                                                            "resource/toolbox": ""})
    kit = write_ament_python(ws / "src", "toolkit", modules={"main.py": "def main():\n    pass\n"},
                             depend=["toolbox"])
    (kit / "setup.py").write_text(TOOLKIT_SETUP)
    _build(ws)
    scripts = ws / "install" / "toolkit" / "lib" / "toolkit"
    assert sorted(p.name for p in scripts.iterdir()) == ["hammer"]
    write(box / "tools" / "saw.tool", "")

    result = _build(ws)

    assert _rebuilt(result) == ["toolbox", "toolkit"], output(result)
    assert sorted(p.name for p in scripts.iterdir()) == ["hammer", "saw"]
