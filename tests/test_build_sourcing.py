"""Sourcing a built workspace in bash, dash and zsh: `set -u`, twice, elsewhere, with spaces."""

from __future__ import annotations

from pathlib import Path

import pytest

from conftest import write_package
from test_build_helpers import (
    PATH_VARS,
    build,
    output,
    print_vars,
    sh_quote,
    shell,
    write_cmake,
)
from wsbuild.build_types.pybuild.paths import site_packages_relpath

SHELLS = {"bash": "setup.bash", "dash": "setup.sh", "zsh": "setup.zsh"}

SRC_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(src_cmake NONE)
file(WRITE ${CMAKE_BINARY_DIR}/src_cmakeConfig.cmake "set(SRC_CMAKE_FOUND TRUE)\\n")
install(FILES ${CMAKE_BINARY_DIR}/src_cmakeConfig.cmake DESTINATION share/${PROJECT_NAME}/cmake)
"""


@pytest.fixture(scope="module", params=["isolated", "merged"])
def spaced_ws(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A built workspace whose path holds spaces, in both layouts."""
    ws = tmp_path_factory.mktemp("sourcing") / "my ros ws"
    src = ws / "src"
    write_package(src, "src_py", "ament_python", ["src_cmake"])
    write_cmake(src, "src_cmake", SRC_CMAKE)
    build(ws, *(["--merge-install"] if request.param == "merged" else []))
    return ws


def _prefix(ws: Path, name: str) -> Path:
    install = ws / "install"
    merged = (install / ".colcon_install_layout").read_text().strip() == "merged"
    return install if merged else install / name


def _source_and_print(ws: Path, shell_name: str, times: int) -> str:
    setup = sh_quote(str(ws / "install" / SHELLS[shell_name]))
    script = print_vars(PATH_VARS).replace('echo "', 'echo "0:')
    for n in range(1, times + 1):
        script += f". {setup}\n" + print_vars(PATH_VARS).replace('echo "', f'echo "{n}:')
    return script


def _vars(stdout: str, n: int) -> dict[str, list[str]]:
    values = {}
    for line in stdout.splitlines():
        if line.startswith(f"{n}:"):
            name, _, value = line[len(f"{n}:"):].partition("=")
            values[name] = [e for e in value.split(":") if e]
    return values


@pytest.mark.parametrize("shell_name", sorted(SHELLS))
def test_sourcing_twice_under_set_u_adds_no_duplicate_entries(spaced_ws: Path,
                                                               shell_name: str) -> None:
    result = shell(_source_and_print(spaced_ws, shell_name, 2), cwd=spaced_ws,
                   shell=shell_name)
    assert result.returncode == 0, output(result)
    assert result.stderr == ""
    before, once, twice = (_vars(result.stdout, n) for n in range(3))
    assert once == twice
    for name, entries in once.items():
        added = [e for e in entries if e not in before[name]]
        assert len(added) == len(set(added)), f"{name} has duplicates: {entries}"
        for entry in before[name]:
            # entries the user had stay, and are not repeated
            assert entries.count(entry) == before[name].count(entry), (name, entry)
    assert str(_prefix(spaced_ws, "src_py")) in once["AMENT_PREFIX_PATH"]
    assert str(_prefix(spaced_ws, "src_cmake")) in once["CMAKE_PREFIX_PATH"]
    assert str(_prefix(spaced_ws, "src_py") / site_packages_relpath()) in once["PYTHONPATH"]
    assert str(spaced_ws / "install") in once["COLCON_PREFIX_PATH"]


@pytest.mark.parametrize("shell_name", sorted(SHELLS))
def test_sourcing_from_another_directory_makes_the_packages_usable(
        spaced_ws: Path, shell_name: str, tmp_path: Path) -> None:
    setup = sh_quote(str(spaced_ws / "install" / SHELLS[shell_name]))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    main = _prefix(spaced_ws, "src_py") / "lib" / "src_py" / "src_py_main"
    script = (f". {setup}\n"
              '"$WSBUILD_TEST_PYTHON" -c "import src_py, os; '
              'print(os.path.dirname(src_py.__file__))"\n'
              f"cd /\n{sh_quote(str(main))}\n"
              "echo \"prefix=${CMAKE_PREFIX_PATH%%:*}\"\n")
    result = shell(script, cwd=elsewhere, shell=shell_name)
    assert result.returncode == 0, output(result)
    assert result.stderr == ""
    lines = result.stdout.splitlines()
    assert Path(lines[0]) == _prefix(spaced_ws, "src_py") / site_packages_relpath() / "src_py"
    assert lines[1] == "hello from src_py"
    assert lines[2] == f"prefix={_prefix(spaced_ws, 'src_cmake')}"


def test_cmake_finds_a_package_of_the_sourced_workspace(spaced_ws: Path, tmp_path: Path) -> None:
    probe = tmp_path / "probe"
    probe.mkdir()
    (probe / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.14)\nproject(probe NONE)\n"
        "find_package(src_cmake REQUIRED)\nmessage(STATUS \"found=${SRC_CMAKE_FOUND}\")\n")
    script = (f". {sh_quote(str(spaced_ws / 'install' / 'setup.bash'))}\n"
              f"cmake -S {sh_quote(str(probe))} -B {sh_quote(str(probe / 'build'))}\n")
    result = shell(script, cwd=tmp_path)
    assert result.returncode == 0, output(result)
    assert "-- found=TRUE" in result.stdout
