"""Critical path first: among ready packages the one with the longest chain of work behind it
starts first, weighted by the durations of the last build (or an estimate)."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest

from test_build_helpers import build, write_cmake
from wsbuild.engine.ready_queue import JobGraph
from wsbuild.engine.schedule import FailurePolicy, run_jobs
from wsbuild.builder.weights import estimate_seconds, package_weights
from wsbuild.engine.timings import read_durations
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.workspace.model import Package

#   a(1) ── c(1)            b(2) ── d(5) ── e(1)
#                                └─ f(1)
DEPS = {"a": set(), "b": set(), "c": {"a"}, "d": {"b"}, "e": {"d"}, "f": {"b"}}
WEIGHTS = {"a": 1, "b": 2, "c": 1, "d": 5, "e": 1, "f": 1}


def remaining_work(dependencies: dict[str, set[str]], weights: dict[str, float]) -> dict[str, float]:
    return JobGraph.of(dependencies, dependencies).remaining_work(weights)


def critical_path(dependencies: dict[str, set[str]], weights: dict[str, float]) -> list[str]:
    return JobGraph.of(dependencies, dependencies).critical_path(weights)


def test_remaining_work_is_own_weight_plus_heaviest_chain_of_dependents() -> None:
    assert remaining_work(DEPS, WEIGHTS) == {"a": 2, "b": 8, "c": 1, "d": 6, "e": 1, "f": 1}


def test_critical_path_is_the_heaviest_chain() -> None:
    assert critical_path(DEPS, WEIGHTS) == ["b", "d", "e"]
    # ties go to the first name in the mapping's order (a missing weight counts 0)
    assert critical_path({"x": set(), "y": set()}, {}) == ["x"]
    assert critical_path(DEPS, {}) == ["a", "c"]
    assert critical_path({}, {}) == []


def test_a_cycle_is_an_error_not_a_hang() -> None:
    with pytest.raises(ValueError, match="cycle"):
        remaining_work({"a": {"b"}, "b": {"a"}}, {})


def _start_order(weights: dict[str, float] | None, workers: int = 1) -> list[str]:
    started: list[str] = []
    lock = threading.Lock()

    def job(name: str) -> JobResult:
        with lock:
            started.append(name)
        return JobResult(name, Outcome.FINISHED)

    run_jobs(JobGraph.of(["a", "b", "c", "d", "e", "f"], DEPS), job, workers=workers,
             policy=FailurePolicy.STOP, emit=lambda e: None, weights=weights)
    return started


def test_ready_jobs_start_by_remaining_work_then_by_order() -> None:
    # a (2 left) loses to b (8 left); after b, d (6) beats a (2) and f (1); then a (2);
    # c, e and f (1 each) tie and go by order
    assert _start_order(WEIGHTS) == ["b", "d", "a", "c", "e", "f"]
    # without weights: the given (topological, by name) order among ready jobs
    assert _start_order(None) == ["a", "b", "c", "d", "e", "f"]


def test_estimate_counts_interfaces_and_sources(tmp_path: Path) -> None:
    def package(name: str, files: list[str], build_type: str = "ament_cmake") -> Package:
        for rel in files:
            (tmp_path / name / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / name / rel).write_text("")
        return Package(name=name, path=tmp_path / name, build_type=build_type)

    msgs = package("msgs", ["msg/A.msg", "msg/B.msg", "srv/C.srv", "action/D.action"])
    lib = package("lib", ["src/a.cpp", "src/b.cpp", "include/lib/a.hpp"])
    py = package("py", ["py/__init__.py"], build_type="ament_python")
    assert estimate_seconds(msgs) > estimate_seconds(lib) > estimate_seconds(py) > 0
    packages = {p.name: p for p in (msgs, lib, py)}
    (tmp_path / "build" / ".wsbuild").mkdir(parents=True)
    (tmp_path / "build" / ".wsbuild" / "durations.json").write_text('{"lib": 99.5}')
    weights = package_weights(packages, ["msgs", "lib", "py"], tmp_path / "build")
    assert weights["lib"] == 99.5 and weights["msgs"] == estimate_seconds(msgs)


SLOW = """cmake_minimum_required(VERSION 3.14)
project({name} NONE)
execute_process(COMMAND sleep {seconds})
"""


def _started(ws: Path) -> list[str]:
    timings = json.loads((ws / "log" / "latest_build" / "timings.json").read_text())
    return [p["package"] for p in sorted(timings["packages"], key=lambda p: p["started"])]


def test_recorded_durations_put_the_long_chain_first(tmp_path: Path) -> None:
    """`aaa` looks heavy (many C++ files, none of them built) but is quick; `zzz_base` starts
    a chain of slow packages. The first build goes by the estimate (aaa first); once it has
    recorded durations, a single worker starts `zzz_base` first."""
    ws = tmp_path / "ws"
    chain = [("zzz_base", []), ("zzz_mid", ["zzz_base"]), ("zzz_top", ["zzz_mid"])]
    write_cmake(ws / "src", "aaa", SLOW.format(name="aaa", seconds=0),
                files={f"unused/f{i}.cpp": "" for i in range(8)})
    for name, deps in chain:
        write_cmake(ws / "src", name, SLOW.format(name=name, seconds=0.6), depend=deps)
    build(ws, "--parallel-workers", "1", "--compiler-cache", "none")
    assert _started(ws)[0] == "aaa"
    durations = read_durations(ws / "build")
    assert set(durations) == {"aaa", "zzz_base", "zzz_mid", "zzz_top"}
    assert durations["zzz_base"] > durations["aaa"]
    result = build(ws, "--parallel-workers", "1", "--compiler-cache", "none",
                   "--cmake-force-configure", "--timings")
    assert _started(ws)[0] == "zzz_base", _started(ws)
    # --timings: one row per package with its phases, and the CPU time against the limit
    assert "configure" in result.stdout and "idle" in result.stdout
    assert "× the lower bound of" in result.stdout
    timings = json.loads((ws / "log" / "latest_build" / "timings.json").read_text())
    assert {"configure", "build", "install"} <= {
        label for p in timings["packages"] for label, _, _ in p["phases"]}
    assert timings["cpu_seconds"]["total"] > 0 and timings["limit_seconds"] > 0
    assert (ws / "log" / "latest_build" / "timings.txt").is_file()


def test_the_start_order_is_the_schedulers_with_one_worker() -> None:
    """A plan's start order (what --dry-run lists) and the scheduler come from one ready
    queue: on many graphs and weights, one worker starts the jobs in the start order."""
    import random

    from wsbuild.engine.ready_queue import start_order

    chooser = random.Random(30)
    for _ in range(200):
        names = [f"p{i}" for i in range(chooser.randint(1, 9))]
        deps = {n: {d for d in names[:i] if chooser.random() < 0.3}
                for i, n in enumerate(names)}
        weights = {n: float(chooser.randint(0, 4)) for n in names if chooser.random() < 0.8}
        jobs = JobGraph.of(names, deps)
        started: list[str] = []
        run_jobs(jobs, lambda name: started.append(name) or JobResult(name, Outcome.FINISHED),
                 workers=1, policy=FailurePolicy.STOP, emit=lambda e: None, weights=weights)
        assert started == start_order(jobs, weights), (deps, weights)
