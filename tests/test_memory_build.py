"""A memory budget on a real build (builder/resources/memory.py, engine/memory.py): CMake packages whose
every compile needs a known amount of memory (a compiler launcher holds it for a while, then
compiles for real), the jobserver at its full size; the build's process tree is sampled from
outside while it runs. The build cache is off: every package must compile in each build."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from benchmarks.memory import tree_rss
from tests.conftest import write_package

pytestmark = pytest.mark.xdist_group("memory_build")

M = 1024 * 1024
#: what each compile holds, and for how long
HOLD_MB, HOLD_SECONDS = 200, 0.8
#: room for one compile beside wsbuild, not for two
BUDGET_MB = 380
LAUNCHER = """import os, sys, time
block = b"x" * (int(sys.argv[1]) << 20)
time.sleep(float(sys.argv[2]))
del block
os.execvp(sys.argv[3], sys.argv[3:])
"""
CMAKELISTS = """cmake_minimum_required(VERSION 3.16)
project({name} CXX)
add_library({name} a.cpp b.cpp c.cpp)
install(TARGETS {name} DESTINATION lib)
"""


def _workspace(tmp_path: Path) -> tuple[Path, list[str]]:
    ws = tmp_path / "ws"
    for name in ("heavy_a", "heavy_b"):
        package = write_package(ws / "src", name, "cmake")
        (package / "CMakeLists.txt").write_text(CMAKELISTS.format(name=name))
        for source in "abc":
            (package / f"{source}.cpp").write_text(f"int {name}_{source}() {{ return 1; }}\n")
    launcher = tmp_path / "hold_memory.py"
    launcher.write_text(LAUNCHER)
    args = ["--no-cache", "--compiler-cache", "none", "--cmake-args",
            f"-DCMAKE_CXX_COMPILER_LAUNCHER={sys.executable};-S;{launcher};{HOLD_MB};"
            f"{HOLD_SECONDS}"]
    return ws, args


def _build_sampled(ws: Path, *args: str) -> tuple[subprocess.CompletedProcess[str], int]:
    """`wsbuild build ARGS` in `ws`, and the peak of its process tree, sampled every 20 ms."""
    env = {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    proc = subprocess.Popen([sys.executable, "-m", "wsbuild", "build", *args], cwd=ws, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peak = 0
    out: list[str] = []
    reader = threading.Thread(target=lambda: out.extend(proc.communicate()))
    reader.start()
    while proc.poll() is None:
        peak = max(peak, tree_rss(proc.pid))
        time.sleep(0.02)
    reader.join()
    return subprocess.CompletedProcess(proc.args, proc.returncode, out[0], out[1]), peak


def test_the_build_stays_within_its_budget_where_without_one_it_goes_beyond(
        tmp_path: Path) -> None:
    ws, args = _workspace(tmp_path)
    # nothing recorded: one package is measured first, then the measures admit
    within, peak = _build_sampled(ws, *args, "--memory-limit", f"{BUDGET_MB}M")
    assert within.returncode == 0, within.stdout + within.stderr
    assert within.stdout.count("Finished <<<") == 2
    assert peak <= BUDGET_MB * M * 1.1, f"peaked at {peak / M:.0f} MiB"
    summary = within.stdout[within.stdout.index("Summary:"):]
    assert f"memory: budget {BUDGET_MB} MiB (--memory-limit {BUDGET_MB}M)" in summary
    assert "peak memory by package: heavy_" in summary
    timings = json.loads((ws / "log" / "latest_build" / "timings.json").read_text())
    memory = timings["memory"]
    assert memory["budget"]["bytes"] == BUDGET_MB * M
    assert HOLD_MB * M <= memory["peak"] <= BUDGET_MB * M * 1.1
    assert {n: p["steps"]["build"]["job"] >= HOLD_MB * M
            for n, p in memory["packages"].items()} == {"heavy_a": True, "heavy_b": True}
    # the run's events show it: the compiles of the two packages never overlapped, and what
    # the summary says they waited covers every phase they spent waiting for memory
    rows = {row["package"]: row for row in timings["packages"]}
    builds = sorted(next((start, end) for label, start, end in row["phases"] if label == "build")
                    for row in rows.values())
    assert builds[1][0] >= builds[0][1]
    waits = [end - start for row in rows.values() for label, start, end in row["phases"]
             if label == "wait for memory"]
    assert memory["waited_seconds"] > 0
    assert memory["waited_seconds"] >= sum(waits) - 0.001 * len(waits)
    report = (ws / "log" / "latest_build" / "report.html").read_text()
    assert "memory budget" in report and "peak memory" in report
    # the same build without a budget, from scratch, holds more than it at once
    for directory in ("build", "install", "log"):
        subprocess.run(["rm", "-rf", str(ws / directory)], check=True)
    beyond, peak = _build_sampled(ws, *args, "--no-memory-limit")
    assert beyond.returncode == 0, beyond.stdout + beyond.stderr
    assert beyond.stdout.count("Finished <<<") == 2
    assert "memory: budget" not in beyond.stdout
    assert peak > BUDGET_MB * M * 1.1, f"peaked at {peak / M:.0f} MiB only"


def test_the_dry_run_names_the_budget_and_where_it_came_from(
        make_workspace, wsbuild) -> None:  # type: ignore[no-untyped-def]
    ws = make_workspace({"pa": ("ament_python", [])})
    given = wsbuild("build", "--dry-run", "--memory-limit", "1.5G", cwd=ws)
    assert given.returncode == 0, given.stderr
    assert "memory budget: 1.5 GiB (--memory-limit 1.5G)" in given.stdout
    default = wsbuild("build", "--dry-run", "--json", cwd=ws)
    budget = json.loads(default.stdout)["memory_budget"]
    assert budget["bytes"] > 0 and ("available at the start" in budget["source"]
                                    or "cgroup's limit" in budget["source"])
    # a defaults file sets it; --no-memory-limit turns it off
    (ws / "wsbuild.yaml").write_text("build:\n  memory-limit: 25%\n")
    shared = wsbuild("build", "--dry-run", cwd=ws)
    assert "memory budget: " in shared.stdout and "(--memory-limit 25% of the" in shared.stdout
    off = wsbuild("build", "--dry-run", "--no-memory-limit", cwd=ws)
    assert "memory budget: none (--no-memory-limit)" in off.stdout
    bad = wsbuild("build", "--memory-limit", "lots", cwd=ws)
    assert bad.returncode == 2 and "--memory-limit 'lots' is no size" in bad.stderr
