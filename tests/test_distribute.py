"""Compiling on distcc hosts (`--distribute`), against real distccd daemons on loopback: the
daemon compiles the workspace's sources, the install tree is the same bytes as a local build's,
ccache in front sends nothing on a hit, a host that does not answer costs one warning and the
budget falls back, and `--timings` says how many compiles ran remotely. The hosts come from
the option, WSBUILD_DISTRIBUTE or a defaults file."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

from distccd_server import Distccd, HangingAfterProbe, distccd, free_port  # noqa: F401
from test_build_basic import write_cpp_workspace
from test_build_helpers import build, clean_env, output, requires_ros, wsbuild, write_cmake
from wsbuild.builder.resources.distcc import (IO_TIMEOUT_SECONDS, count_compile_jobs,
                                        distribute_spec, parse_hosts,
                                        remote_wait_bounds)
from wsbuild.builder.request import cpu_count

LIBD = """cmake_minimum_required(VERSION 3.14)
project(libd CXX)
add_library(libd SHARED src/a.cpp src/b.cpp src/c.cpp src/d.cpp)
target_include_directories(libd PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                       $<INSTALL_INTERFACE:include>)
install(TARGETS libd EXPORT libdTargets DESTINATION lib)
install(DIRECTORY include/ DESTINATION include)
install(EXPORT libdTargets FILE libdConfig.cmake DESTINATION share/libd/cmake)
"""

APPD = """cmake_minimum_required(VERSION 3.14)
project(appd CXX)
find_package(libd REQUIRED)
add_executable(appd src/main.cpp src/words.cpp)
target_link_libraries(appd libd)
install(TARGETS appd DESTINATION bin)
"""

LIB_SOURCES = ("a.cpp", "b.cpp", "c.cpp", "d.cpp")
SOURCES = (*LIB_SOURCES, "main.cpp", "words.cpp")


def _workspace(root: Path, *, ament: bool = False) -> Path:
    """libd (four sources) and appd (two) as plain CMake packages; with `ament`, also
    test_build_basic's ament_cmake library and program (mylib.cpp, main.cpp)."""
    ws = root / "ws"
    src = ws / "src"
    if ament:
        write_cpp_workspace(ws)
    files = {"include/libd/libd.hpp": "#pragma once\n"
             + "".join(f"int {n[0]}_count(int n);\n" for n in LIB_SOURCES)}
    for name in LIB_SOURCES:
        files[f"src/{name}"] = (
            '#include <map>\n#include <string>\n#include <vector>\n#include "libd/libd.hpp"\n'
            f"int {name[0]}_count(int n) {{ std::map<std::string, std::vector<int>> m;\n"
            f'  m["{name}"].assign(n, 1); return (int)m["{name}"].size(); }}\n')
    write_cmake(src, "libd", LIBD, files=files)
    write_cmake(src, "appd", APPD, depend=["libd"], files={
        "src/words.cpp": "#include <string>\nstd::string words() { return \"answer\"; }\n",
        "src/main.cpp": '#include <cstdio>\n#include <string>\n#include "libd/libd.hpp"\n'
                        "std::string words();\nint main() { std::printf(\"%s %d\\n\", "
                        "words().c_str(), a_count(40) + b_count(2)); return 0; }\n"})
    return ws


def _env(tmp_path: Path) -> dict[str, str]:
    env = clean_env(CCACHE_DIR=str(tmp_path / "ccache"))
    for name in ("DISTCC_HOSTS", "WSBUILD_DISTRIBUTE", "DISTCC_DIR", "DISTCC_LOG"):
        env.pop(name, None)
    return env


def _tree(root: Path) -> dict[str, str]:
    """Every file and link under `root` by content."""
    tree = {}
    for path in sorted(root.rglob("*")):
        rel = str(path.relative_to(root))
        if path.is_symlink():
            tree[rel] = "-> " + str(path.readlink())
        elif path.is_file():
            tree[rel] = hashlib.sha256(path.read_bytes()).hexdigest()
    return tree


def _timings(ws: Path) -> dict[str, object]:
    return json.loads((ws / "log" / "latest_build" / "timings.json").read_text())


def _from_scratch(ws: Path) -> None:
    shutil.rmtree(ws / "build")
    shutil.rmtree(ws / "install")


def _warnings(result: subprocess.CompletedProcess[str]) -> list[str]:
    return [line for line in (result.stdout + result.stderr).splitlines() if "WARNING" in line]


def _launchers(ws: Path, name: str) -> set[str]:
    cache = (ws / "build" / name / "CMakeCache.txt").read_text()
    return {line.split("=", 1)[1] for line in cache.splitlines()
            if line.startswith("CMAKE_CXX_COMPILER_LAUNCHER")}


@requires_ros
def test_the_daemon_compiles_and_the_install_tree_is_the_same_bytes(
        tmp_path: Path, distccd: Callable[..., Distccd]) -> None:
    daemon = distccd()
    ws = _workspace(tmp_path, ament=True)
    env = _env(tmp_path)
    build(ws, "--no-cache", "--compiler-cache", "none", env=env)
    local = _tree(ws / "install")
    _from_scratch(ws)

    done = build(ws, "--no-cache", "--compiler-cache", "none",
                 "--distribute", f"{daemon.host}/4", "--timings", env=env)
    sources = sorted([*SOURCES, "mylib.cpp", "main.cpp"])
    assert sorted(daemon.compiled()) == sources
    assert _tree(ws / "install") == local
    assert _launchers(ws, "libd") == _launchers(ws, "mylib") == {shutil.which("distcc")}
    assert f"distributed compiles: {len(sources)} of {len(sources)} ran remotely" in done.stdout
    timings = _timings(ws)
    assert timings["compile_jobs"] == {"remote": len(sources), "local": 0, "fell_back": 0,
                                       "hosts": ["127.0.0.1"], "lost": []}
    assert timings["job_budget"] == cpu_count() + 4
    assert _warnings(done) == []
    program = subprocess.run([str(ws / "install" / "appd" / "bin" / "appd")], env=dict(
        env, LD_LIBRARY_PATH=str(ws / "install" / "libd" / "lib")), capture_output=True,
        text=True, check=True)
    assert program.stdout == "answer 42\n"


def test_ccache_in_front_sends_only_misses(tmp_path: Path,
                                           distccd: Callable[..., Distccd]) -> None:
    daemon = distccd()
    ws = _workspace(tmp_path)
    env = _env(tmp_path)
    first = build(ws, "--no-cache", "--compiler-cache", "ccache", "--timings",
                  "--distribute", f"{daemon.host}/4", env=env)
    assert _launchers(ws, "libd") == {shutil.which("ccache")}
    assert f"compiler cache (ccache): 0 hits, {len(SOURCES)} misses" in first.stdout
    assert sorted(daemon.compiled()) == sorted(SOURCES)
    _from_scratch(ws)

    again = build(ws, "--no-cache", "--compiler-cache", "ccache", "--timings",
                  "--distribute", f"{daemon.host}/4", env=env)
    assert f"compiler cache (ccache): {len(SOURCES)} hits, 0 misses" in again.stdout
    assert sorted(daemon.compiled()) == sorted(SOURCES)  # nothing more was sent
    assert _timings(ws)["compile_jobs"]["remote"] == 0


def test_a_host_not_listening_costs_one_warning_and_builds_locally(tmp_path: Path) -> None:
    ws = _workspace(tmp_path)
    env = _env(tmp_path)
    port = free_port()
    # the hosts from the workspace's defaults file, as a team would keep them
    (ws / "wsbuild.yaml").write_text(f"build:\n  distribute: 127.0.0.1:{port}/4\n")
    done = build(ws, "--no-cache", "--compiler-cache", "none", env=env)
    warnings = _warnings(done)
    assert len(warnings) == 1, output(done)
    assert f"127.0.0.1:{port}/4 not used" in warnings[0] and "building locally" in warnings[0]
    timings = _timings(ws)
    assert timings["job_budget"] == cpu_count()  # the budget fell back to the local cores
    assert "compile_jobs" not in timings
    assert _launchers(ws, "libd") == set()
    assert (ws / "install" / "appd" / "bin" / "appd").is_file()


def test_of_two_hosts_the_one_down_is_dropped_and_the_other_compiles(
        tmp_path: Path, distccd: Callable[..., Distccd]) -> None:
    daemon = distccd()
    ws = _workspace(tmp_path)
    env = _env(tmp_path)
    down = f"127.0.0.1:{free_port()}/8"
    done = build(ws, "--no-cache", "--compiler-cache", "none",
                 env={**env, "WSBUILD_DISTRIBUTE": f"{down} {daemon.host}/3"})
    warnings = _warnings(done)
    assert len(warnings) == 1 and f"{down} not used" in warnings[0], output(done)
    assert "compiling on the others" in warnings[0]
    assert sorted(daemon.compiled()) == sorted(SOURCES)
    assert _timings(ws)["job_budget"] == cpu_count() + 3


def test_a_host_lost_during_the_run_costs_one_warning_and_its_slots(
        tmp_path: Path, distccd: Callable[..., Distccd]) -> None:
    daemon = distccd()
    ws = _workspace(tmp_path)
    # the host goes down after the probe, while the first package configures
    cmakelists = ws / "src" / "libd" / "CMakeLists.txt"
    cmakelists.write_text(cmakelists.read_text().replace(
        "project(libd CXX)\n",
        f"project(libd CXX)\nexecute_process(COMMAND kill -TERM -- -{daemon.process.pid})\n"))
    env = _env(tmp_path)
    done = build(ws, "--no-cache", "--compiler-cache", "none", "--timings",
                 "--distribute", f"{daemon.host}/4", env=env)
    warnings = _warnings(done)
    assert len(warnings) == 1, output(done)
    assert f"{len(SOURCES)} compile job(s) could not be distributed" in warnings[0]
    assert f"{daemon.host}/4 failed: its slots left the job budget" in warnings[0]
    jobs = _timings(ws)["compile_jobs"]
    assert (jobs["remote"], jobs["local"], jobs["fell_back"]) == (0, len(SOURCES), len(SOURCES))
    assert jobs["lost"] == [f"{daemon.host}/4"]
    assert daemon.compiled() == []
    assert (ws / "install" / "appd" / "bin" / "appd").is_file()


def test_a_host_that_hangs_after_the_probe_costs_one_bounded_wait(
        tmp_path: Path, distccd: Callable[..., Distccd]) -> None:
    """The host passes the probe, then takes compile jobs and never answers: the jobs in flight
    wait IO_TIMEOUT_SECONDS (not distcc's 300 s) and compile here; no later job is sent."""
    hanging = HangingAfterProbe(distccd())
    ws = _workspace(tmp_path)
    try:
        done = build(ws, "--no-cache", "--compiler-cache", "none", "--distribute",
                     f"{hanging.host}/4", env=_env(tmp_path))
        sent = len(hanging.hung)
    finally:
        hanging.stop()
    warnings = _warnings(done)
    assert len(warnings) == 1, output(done)
    assert f"{hanging.host}/4 failed: its slots left the job budget" in warnings[0]
    log = (ws / "log" / "latest_build" / "distcc.log").read_text()
    waited = re.findall(rf"failed to distribute (\S+) to {re.escape(hanging.host)}", log)
    # libd's compiles were in flight together when the host hung; appd's came after: not sent
    assert waited and {Path(w).name for w in waited} <= set(LIB_SOURCES), log
    assert sent == len(waited)
    elapsed = [float(s) for s in re.findall(r"elapsed compilation time ([\d.]+)s", log)]
    assert len(elapsed) == len(SOURCES)
    assert IO_TIMEOUT_SECONDS <= max(elapsed) < IO_TIMEOUT_SECONDS + 10, elapsed
    assert (ws / "install" / "appd" / "bin" / "appd").is_file()


def test_remote_waits_are_bounded_unless_the_user_bounded_them() -> None:
    assert remote_wait_bounds({}) == {"DISTCC_IO_TIMEOUT": str(IO_TIMEOUT_SECONDS),
                                      "DISTCC_BACKOFF_PERIOD": str(7 * 24 * 3600)}
    assert remote_wait_bounds({"DISTCC_IO_TIMEOUT": "600", "DISTCC_BACKOFF_PERIOD": "0"}) == {}


def test_a_withheld_share_of_the_budget_leaves_the_fifo() -> None:
    from wsbuild.engine.jobserver import Jobserver

    jobserver = Jobserver(6)  # 5 tokens in the FIFO, one implicit
    try:
        jobserver.withhold(3)
        deadline = time.monotonic() + 5
        while jobserver.withheld < 3 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert jobserver.withheld == 3
        os.set_blocking(jobserver.read_fd, False)
        left = os.read(jobserver.read_fd, 10)
        assert len(left) == 2
        os.write(jobserver.write_fd, left)
    finally:
        jobserver.close()


def test_links_run_through_the_local_gate_which_goes_away_with_distribution(
        tmp_path: Path, distccd: Callable[..., Distccd]) -> None:
    daemon = distccd()
    ws = _workspace(tmp_path)
    env = _env(tmp_path)
    build(ws, "--no-cache", "--compiler-cache", "none", "--distribute", daemon.host, env=env)
    ninja = (ws / "build" / "libd" / "build.ninja").read_text()
    assert "local_gate.sh" in ninja
    build(ws, "--no-cache", "--compiler-cache", "none", "--force", env=env)
    assert "local_gate.sh" not in (ws / "build" / "libd" / "build.ninja").read_text()
    # a second local build does not configure again
    build(ws, "--no-cache", "--compiler-cache", "none", "--force", env=env)
    log = (ws / "log" / "latest_build" / "libd" / "stdout_stderr.log").read_text()
    assert "Configuring done" not in log


def test_sccache_with_distribution_is_refused_with_a_reason(tmp_path: Path) -> None:
    ws = _workspace(tmp_path)
    done = wsbuild("build", "--no-cache", "--compiler-cache", "sccache",
                   "--distribute", "127.0.0.1/4", cwd=ws, env=_env(tmp_path))
    assert done.returncode == 2, output(done)
    assert "--distribute needs ccache" in done.stderr
    assert "--compiler-cache ccache" in done.stderr


def test_hosts_come_from_the_option_then_the_environment_and_off_wins() -> None:
    assert distribute_spec(None, {}) is None
    assert distribute_spec("a/4", {"WSBUILD_DISTRIBUTE": "b/4"}) == "a/4"
    assert distribute_spec(None, {"WSBUILD_DISTRIBUTE": "b/4", "DISTCC_HOSTS": "c"}) == "b/4"
    assert distribute_spec(None, {"DISTCC_HOSTS": "c/2"}) == "c/2"
    assert distribute_spec("off", {"DISTCC_HOSTS": "c/2"}) is None
    assert distribute_spec(None, {"WSBUILD_DISTRIBUTE": "off", "DISTCC_HOSTS": "c"}) is None


def test_host_lists_read_like_distcc() -> None:
    options, hosts = parse_hosts("--localslots=3 localhost box1/16 box2:3633/8,lzo @box3 "
                                 "[::1]:3632/2")
    assert options == ["--localslots=3"]
    assert [(h.name, h.slots, h.local) for h in hosts] == [
        ("localhost", 2, True), ("box1", 16, False), ("box2", 8, False), ("@box3", 4, False),
        ("[::1]", 2, False)]


def test_counts_come_from_distccs_log(tmp_path: Path) -> None:
    log = tmp_path / "distcc.log"
    log.write_text(
        "distcc[1] compile a.cpp on 10.0.0.2:3632/4 completed ok\n"
        "distcc[1] cpp a.cpp on localhost completed ok\n"
        "distcc[2] (dcc_build_somewhere) Warning: failed to distribute, running locally "
        "instead\n"
        "distcc[2] compile b.cpp on localhost completed ok\n")
    jobs = count_compile_jobs(log, ["10.0.0.2"])
    assert (jobs.remote, jobs.local, jobs.fell_back) == (1, 1, 1)
