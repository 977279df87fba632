"""CMake options of `wsbuild build`: targets, clean-first, cache handling, compile_commands.json,
and the shared make jobserver."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from test_build_helpers import build, write_cmake

# the tests build one workspace in turn and read the latest run's logs
pytestmark = pytest.mark.xdist_group("cmake_options")

CPP = """cmake_minimum_required(VERSION 3.14)
project({name} CXX)
add_executable({name}_main main.cpp)
add_custom_target(extra_{name} COMMAND ${{CMAKE_COMMAND}} -E touch extra_built)
install(TARGETS {name}_main DESTINATION bin)
"""


@pytest.fixture(scope="module")
def ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("cmakeopts") / "ws"
    for name in ("alpha", "beta"):
        write_cmake(root / "src", name, CPP.format(name=name),
                    files={"main.cpp": "int main() { return 0; }\n"})
    build(root)
    return root


def test_compile_commands_are_merged(ws: Path) -> None:
    entries = json.loads((ws / "build" / "compile_commands.json").read_text())
    files = sorted(Path(e["file"]).parent.name for e in entries)
    assert files == ["alpha", "beta"]


def test_cmake_target_builds_that_target(ws: Path) -> None:
    build(ws, "--packages-select", "alpha", "--cmake-target", "extra_alpha")
    assert (ws / "build" / "alpha" / "extra_built").exists()


def test_reconfigure_only_when_needed(ws: Path) -> None:
    log = ws / "log" / "latest_build" / "alpha" / "stdout_stderr.log"
    build(ws, "--packages-select", "alpha", "--force")
    assert "Configuring done" not in log.read_text()  # cache exists, arguments unchanged
    build(ws, "--packages-select", "alpha", "--cmake-force-configure")
    assert "Configuring done" in log.read_text()
    cache = ws / "build" / "alpha" / "CMakeCache.txt"
    cache.write_text(cache.read_text() + "WSBUILD_TEST_MARK:STRING=1\n")
    build(ws, "--packages-select", "alpha", "--cmake-clean-cache")
    assert "WSBUILD_TEST_MARK" not in cache.read_text()


def test_clean_first_recompiles(ws: Path) -> None:
    build(ws, "--packages-select", "beta", "--cmake-clean-first")
    log = (ws / "log" / "latest_build" / "beta" / "stdout_stderr.log").read_text()
    assert "Building CXX object" in log


def test_one_jobserver_is_shared(ws: Path) -> None:
    build(ws, "--packages-select", "beta", "--force")
    command_log = (ws / "log" / "latest_build" / "beta" / "command.log").read_text()
    assert "--jobserver-auth=" in command_log


def test_cmake_message_output_is_not_reported_as_a_warning(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "chatty", "cmake_minimum_required(VERSION 3.14)\nproject(chatty NONE)\n"
                "message(\"just saying hello\")\nmessage(WARNING \"a real problem\")\n")
    out = build(ws).stdout
    assert "--- warnings: chatty" in out and "a real problem" in out
    assert "just saying hello" not in out
    log = (ws / "log" / "latest_build" / "chatty" / "stdout_stderr.log").read_text()
    assert "just saying hello" in log
