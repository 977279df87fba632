"""The build-step oracle (builder/oracles/step_trace.py): with WSBUILD_STEP_TRACE naming a file, each
command step of a build (and the warm helper that reads a setup.py) runs under strace, and each
file a step read that the package's record does not hold is written to that file, naming the
package, the step and the file; nothing is exempt for where it lies. The suite runs the builds
of its up-to-date, observed-inputs, early-cutoff and churn tests under it (tests/conftest.py's
`traced_steps`), and a finding fails the test that caused it."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from test_build_helpers import clean_env, output, write, write_ament_python, write_cmake
from test_build_helpers import wsbuild as run

from wsbuild.builder.oracles.step_trace import CHECKED_SUFFIX, step_reads

#: a custom command whose program reads a file outside the package by raw system calls, which
#: no C library function sees (the observer interposes the C library's): the record cannot
#: hold it, strace sees it
SNEAKY = """
cmake_minimum_required(VERSION 3.16)
project(sneaky C)
add_executable(rawcat rawcat.c)
add_custom_command(OUTPUT copied.txt
  COMMAND rawcat ${CMAKE_CURRENT_SOURCE_DIR}/../../outside/secret_input.txt > copied.txt
  DEPENDS rawcat)
add_custom_target(copy ALL DEPENDS copied.txt)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/copied.txt package.xml DESTINATION share/sneaky)
"""
RAWCAT = """#include <fcntl.h>
#include <sys/syscall.h>
#include <unistd.h>
int main(int argc, char **argv) {
    char buffer[256];
    long fd = syscall(SYS_openat, AT_FDCWD, argv[1], O_RDONLY);
    long n = fd < 0 ? 0 : syscall(SYS_read, fd, buffer, sizeof buffer);
    syscall(SYS_write, 1, buffer, n > 0 ? n : 0);
    return argc > 1 ? 0 : 1;
}
"""


def test_a_step_that_reads_a_file_no_list_names_is_named(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    secret = write(ws / "outside" / "secret_input.txt", "hidden\n")
    write_cmake(ws / "src", "sneaky", SNEAKY, files={"rawcat.c": RAWCAT})
    oracle = tmp_path / "steps.txt"
    result = run("build", cwd=ws, env=clean_env(WSBUILD_STEP_TRACE=str(oracle)))
    assert result.returncode == 0, output(result)
    lines = oracle.read_text().splitlines()
    assert f"sneaky\tbuild (cmake)\t{secret}" in lines, lines
    # the reproduce line of a step is the command itself, never strace
    log = (ws / "log" / "latest_build" / "sneaky" / "command.log").read_text()
    assert "strace" not in log


def test_what_the_record_holds_is_not_named_and_every_step_is_checked(tmp_path: Path) -> None:
    """A C++ package reading a header and a CMake file from outside, a Python package built
    by the PEP 517 fallback (a command step) and one by the fast path (the warm helper, traced
    from its start): every read is in their records, the underlay's and the system's too."""
    ws = tmp_path / "ws"
    header = write(ws / "third_party" / "answer.h", "#define ANSWER 42\n")
    write(ws / "cmake" / "flags.cmake", "add_compile_definitions(FLAG=1)\n")
    write_cmake(ws / "src", "asker", f"""
        cmake_minimum_required(VERSION 3.16)
        project(asker CXX)
        include(${{CMAKE_CURRENT_SOURCE_DIR}}/../../cmake/flags.cmake)
        include_directories({header.parent})
        add_executable(asker main.cpp)
        install(TARGETS asker DESTINATION bin)
        install(FILES package.xml DESTINATION share/asker)
        """, files={"main.cpp": '#include "answer.h"\nint main() { return ANSWER - 42; }\n'})
    pkg = write_ament_python(ws / "src", "wheel_built", modules={"main.py": "X = 1\n"})
    write(pkg / "pyproject.toml", '[build-system]\nrequires = ["setuptools"]\n'
          'build-backend = "setuptools.build_meta"\n')
    write_ament_python(ws / "src", "fast_path", modules={"main.py": "X = 1\n"})
    oracle = tmp_path / "steps.txt"
    result = run("build", cwd=ws, env=clean_env(WSBUILD_STEP_TRACE=str(oracle)))
    assert result.returncode == 0, output(result)
    assert not oracle.exists() or oracle.read_text() == "", oracle.read_text()
    checked = {line.split("\t")[3]: line.split("\t") for line in
               Path(f"{oracle}{CHECKED_SUFFIX}").read_text().splitlines()}
    assert int(checked["asker"][0]) == 3 and int(checked["asker"][1]) > 100, checked
    # the fast path's setup.py read in a helper traced from its start: setuptools' modules
    assert int(checked["fast_path"][0]) >= 1 and int(checked["fast_path"][1]) > 100, checked


def test_the_suites_step_oracle_is_on_where_a_test_asks(traced_steps: Path,
                                                        tmp_path: Path) -> None:
    """The fixture the up-to-date, early-cutoff and churn tests use sets the oracle's file: a
    build there is traced and counted (with the oracle off, this fails)."""
    assert os.environ.get("WSBUILD_STEP_TRACE") == str(traced_steps)
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "counted", "cmake_minimum_required(VERSION 3.16)\n"
                "project(counted NONE)\ninstall(FILES package.xml DESTINATION share/counted)\n")
    result = run("build", cwd=ws)
    assert result.returncode == 0, output(result)
    checked = Path(f"{traced_steps}{CHECKED_SUFFIX}").read_text().splitlines()
    assert any(line.endswith("\tcounted") and int(line.split("\t")[0]) >= 2
               for line in checked), checked[-3:]


def test_a_trace_is_read_as_opens_for_reading_directories_writes_and_programs(
        tmp_path: Path) -> None:
    trace = tmp_path / "t.strace"
    trace.write_text(
        '12 execve("/usr/bin/cc", ["cc"], 0x7ff /* 3 vars */) = 0\n'
        '12 openat(AT_FDCWD</b>, "x.h", O_RDONLY|O_CLOEXEC) = 3</src/x.h>\n'
        '12 openat(AT_FDCWD</b>, "out.o", O_WRONLY|O_CREAT|O_TRUNC, 0666) = 4</b/out.o>\n'
        '12 openat(AT_FDCWD</b>, "/b/out.o", O_RDONLY) = 5</b/out.o>\n'
        '12 openat(AT_FDCWD</b>, "/glob", O_RDONLY|O_NONBLOCK|O_CLOEXEC|O_DIRECTORY) = 6</glob>\n'
        '12 openat(AT_FDCWD</b>, "/missing.h", O_RDONLY) = -1 ENOENT (No such file)\n')
    reads = step_reads(trace)
    assert reads.read == ("/src/x.h",)
    assert reads.directories == ("/glob",)
    assert reads.written == frozenset({"/b/out.o"})
    assert os.path.realpath("/usr/bin/cc") in reads.programs


def test_the_sample_workspaces_interfaces_library_and_app_read_nothing_their_records_lack(
        traced_steps: Path, tmp_path: Path) -> None:
    """sample_ws's rosidl interfaces (generators in Python importing numpy and the underlay's
    libraries), its C++ library (gtest archived by `ar`, which loads the linker plugins and
    the libraries they need) and its app, built from scratch with every step traced: every
    read is in their records (the fixture fails the test on any finding)."""
    ws = tmp_path / "ws"
    shutil.copytree(Path(__file__).parents[1] / "sample_ws" / "src", ws / "src",
                    ignore=shutil.ignore_patterns("__pycache__", ".pytest_cache"))
    result = run("build", "--no-cache", "--packages-up-to", "demo_cpp_app", "demo_interfaces",
                 cwd=ws)
    assert result.returncode == 0, output(result)
    checked = {line.split("\t")[3]: line.split("\t") for line in
               Path(f"{traced_steps}{CHECKED_SUFFIX}").read_text().splitlines()}
    for package in ("demo_interfaces", "demo_cpp_lib", "demo_cpp_app"):
        steps, reads = int(checked[package][0]), int(checked[package][1])
        assert steps == 3 and reads > 500, (package, checked[package])
