"""CMake packages build with Ninja when it is installed (make otherwise), honour a generator the
user chose, reconfigure cleanly when the generator changes, and share one CPU budget."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from test_build_helpers import build, clean_env, output, run_wsbuild, write_cmake

LIB = """cmake_minimum_required(VERSION 3.14)
project({name} CXX)
add_library({name} SHARED lib.cpp)
install(TARGETS {name} DESTINATION lib)
"""

#: a wsbuild that finds no ninja anywhere (the tests' venv has one, and so may /usr/bin)
WITHOUT_NINJA = ("import sys, wsbuild.build_types.cmake as cmake; "
                 "cmake.find_ninja = lambda environ: None; "
                 "from wsbuild.cli import main; sys.exit(main())")


def _cpp(ws: Path, name: str = "lib_a") -> Path:
    return write_cmake(ws / "src", name, LIB.format(name=name),
                       files={"lib.cpp": f"int {name}_answer() {{ return 42; }}\n"})


def _cache(ws: Path, name: str = "lib_a") -> str:
    return (ws / "build" / name / "CMakeCache.txt").read_text()


def test_ninja_by_default_joining_the_jobserver_fifo(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _cpp(ws)
    result = build(ws, "--compiler-cache", "none")
    assert (ws / "build" / "lib_a" / "build.ninja").is_file()
    assert not (ws / "build" / "lib_a" / "Makefile").exists()
    assert "CMAKE_GENERATOR:INTERNAL=Ninja" in _cache(ws)
    assert (ws / "install" / "lib_a" / "lib" / "liblib_a.so").is_file()
    log = (ws / "log" / "latest_build" / "lib_a" / "stdout_stderr.log").read_text()
    # the venv's Ninja (>= 1.13) takes its share of the budget from wsbuild's FIFO jobserver
    assert "Jobserver mode detected" in log and "fifo:" in log
    assert "Ignoring jobserver" not in log and "warning" not in result.stdout.lower()


def test_make_when_no_ninja_without_warnings(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _cpp(ws)
    env = clean_env()
    done = _run_without_ninja(ws, env)
    assert done.returncode == 0, output(done)
    assert (ws / "build" / "lib_a" / "Makefile").is_file()
    assert not (ws / "build" / "lib_a" / "build.ninja").exists()
    assert "CMAKE_GENERATOR:INTERNAL=Unix Makefiles" in _cache(ws)
    assert "warning" not in (done.stdout + done.stderr).lower()
    assert "ninja" not in (done.stdout + done.stderr).lower()


def test_generator_from_cmake_args_wins_and_a_switch_reconfigures_from_scratch(
        tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _cpp(ws)
    build(ws, "--compiler-cache", "none")
    assert "CMAKE_GENERATOR:INTERNAL=Ninja" in _cache(ws)
    # the user asks for make: a clean configure with a message, not CMake's generator error
    switched = build(ws, "--compiler-cache", "none", "--cmake-args", "-G", "Unix Makefiles")
    assert "configured with the 'Ninja' generator" in switched.stdout, switched.stdout
    assert "'Unix Makefiles': configuring it from scratch" in switched.stdout
    assert "CMAKE_GENERATOR:INTERNAL=Unix Makefiles" in _cache(ws)
    assert (ws / "build" / "lib_a" / "Makefile").is_file()
    assert (ws / "install" / "lib_a" / "lib" / "liblib_a.so").is_file()
    # and back to the default (Ninja) once the option is gone (--no-cache: the build cache
    # would restore the first build's install, and this test watches the build directory)
    back = build(ws, "--compiler-cache", "none", "--no-cache")
    assert "configured with the 'Unix Makefiles' generator" in back.stdout
    assert "CMAKE_GENERATOR:INTERNAL=Ninja" in _cache(ws)


def test_a_build_dir_made_with_make_switches_to_ninja(tmp_path: Path) -> None:
    """A workspace built before Ninja was installed: the next rebuild moves to Ninja."""
    ws = tmp_path / "ws"
    pkg = _cpp(ws)
    done = _run_without_ninja(ws, clean_env())
    assert done.returncode == 0, output(done)
    (pkg / "lib.cpp").write_text("int lib_a_answer() { return 43; }\n")
    result = build(ws, "--compiler-cache", "none")
    assert "configured with the 'Unix Makefiles' generator" in result.stdout
    assert "CMAKE_GENERATOR:INTERNAL=Ninja" in _cache(ws)


def test_ninja_packages_share_one_cpu_budget(tmp_path: Path) -> None:
    """Two packages of four 0.4 s jobs each, built at once with a budget of 2 jobs: Ninja's
    default would run 2 × (CPUs + 2) at a time; through the jobserver at most
    budget - 1 tokens + one implicit slot per running Ninja = 3 run at once."""
    ws = tmp_path / "ws"
    stamps = tmp_path / "stamps"
    stamps.mkdir()
    script = tmp_path / "job.sh"
    script.write_text('echo start $(date +%s.%N) >> "$1"; sleep 0.4\n'
                      'echo end $(date +%s.%N) >> "$1"; touch "$2"\n')
    for name in ("alpha", "beta"):
        jobs = "\n".join(
            f"add_custom_command(OUTPUT job{i} COMMAND sh {script} {stamps}/{name}{i} job{i})"
            for i in range(4))
        write_cmake(ws / "src", name, f"cmake_minimum_required(VERSION 3.14)\n"
                    f"project({name} NONE)\n{jobs}\n"
                    f"add_custom_target(all_jobs ALL DEPENDS job0 job1 job2 job3)\n")
    env = clean_env()
    done = run_wsbuild("build", "--parallel-workers", "2", "--compiler-cache", "none",
                       cwd=ws, env=env)
    assert done.returncode == 0, output(done)
    events: list[tuple[float, int]] = []
    for path in stamps.iterdir():
        fields = dict(line.split() for line in path.read_text().splitlines())
        events += [(float(fields["start"]), 1), (float(fields["end"]), -1)]
    assert len(events) == 16
    running = peak = 0
    for _, step in sorted(events, key=lambda e: (e[0], e[1])):
        running += step
        peak = max(peak, running)
    budget = len(os.sched_getaffinity(0))
    assert peak <= budget + 1, f"{peak} jobs ran at once with a budget of {budget}"


def _run_without_ninja(ws: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", WITHOUT_NINJA, "build", "--compiler-cache",
                           "none"], cwd=ws, env=env, capture_output=True, text=True,
                          timeout=300)


@pytest.mark.parametrize("spelling", [["-G", "Ninja"], ["-GNinja"]])
def test_user_generator_spellings(tmp_path: Path, spelling: list[str]) -> None:
    from wsbuild.build_types.cmake import user_generator

    assert user_generator(spelling, {}) == "Ninja"
    assert user_generator(["-DX=1"], {"CMAKE_GENERATOR": "Unix Makefiles"}) == "Unix Makefiles"
    assert user_generator(["-DX=1"], {}) is None
