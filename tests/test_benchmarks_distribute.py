"""benchmarks/distribute.py: Ninja's graph and log read into jobs, and the simulation of M
machines (compiles anywhere, everything else on the first machine, critical path first)."""

from __future__ import annotations

import json
from pathlib import Path

from benchmarks.distribute import (
    PackageTimes,
    job_graph,
    load_recording,
    ninja_jobs,
    predict,
    read_ninja_log,
    simulate,
    simulate_shards,
)

#: `ninja -t graph` of a library of two sources and a generated header (shortened ids)
GRAPH = """digraph ninja {
rankdir="LR"
"0x1" [label="all"]
"0x2" -> "0x1" [label=" phony"]
"0x2" [label="liblibd.so"]
"0x3" [label="CXX_SHARED_LIBRARY_LINKER__libd_", shape=ellipse]
"0x3" -> "0x2"
"0x4" -> "0x3" [arrowhead=none]
"0x5" -> "0x3" [arrowhead=none]
"0x4" [label="CMakeFiles/libd.dir/a.cpp.o"]
"0x6" [label="CXX_COMPILER__libd_", shape=ellipse]
"0x6" -> "0x4"
"0x7" -> "0x6" [arrowhead=none]
"0x8" -> "0x6" [arrowhead=none style=dotted]
"0x7" [label="/src/a.cpp"]
"0x8" [label="cmake_object_order_depends_target_libd"]
"0x9" -> "0x8" [label=" phony"]
"0x9" [label="gen.hpp"]
"0xa" [label="CUSTOM_COMMAND", shape=ellipse]
"0xa" -> "0x9"
"0xb" -> "0xa" [arrowhead=none]
"0xb" [label="/src/gen.py"]
"0x5" [label="CMakeFiles/libd.dir/b.cpp.o"]
"0xc" [label="CXX_COMPILER__libd_", shape=ellipse]
"0xc" -> "0x5"
"0xd" -> "0xc" [arrowhead=none]
"0x8" -> "0xc" [arrowhead=none style=dotted]
"0xd" [label="/src/b.cpp"]
}
"""

LOG = """# ninja log v7
0\t1000\t1\tgen.hpp\taa
1000\t5000\t1\tCMakeFiles/libd.dir/a.cpp.o\tbb
1000\t5000\t1\tCMakeFiles/libd.dir/b.cpp.o\tcc
5000\t6000\t1\tliblibd.so\tdd
"""


def _recording(tmp_path: Path, packages: int = 1) -> Path:
    folder = tmp_path / "record"
    (folder / "ninja").mkdir(parents=True)
    rows = []
    for number in range(packages):
        name = f"pkg{number}"
        (folder / "ninja" / f"{name}.log").write_text(LOG)
        (folder / "ninja" / f"{name}.dot").write_text(GRAPH)
        start = number * 8.0
        rows.append({"package": name, "outcome": "finished", "ready": start, "started": start,
                     "finished": start + 8.0, "idle": 0.0,
                     "phases": [["configure", start, start + 1.0],
                                ["build", start + 1.0, start + 7.5],
                                ["install", start + 7.5, start + 8.0]]})
    wall = packages * 8.0 + 0.5
    (folder / "timings.json").write_text(json.dumps(
        {"wall_seconds": wall, "cores": 2, "packages": rows}))
    (folder / "deps.json").write_text(json.dumps(
        {f"pkg{n}": [f"pkg{n - 1}"] if n else [] for n in range(packages)}))
    return folder


def test_ninja_jobs_wait_for_what_they_need_through_phony_edges(tmp_path: Path) -> None:
    log_file = tmp_path / "ninja_log"
    log_file.write_text(LOG)
    jobs = ninja_jobs(GRAPH, read_ninja_log(log_file))
    by_output = {job.outputs[0]: job for job in jobs}
    names = [job.outputs[0] for job in jobs]
    generated = names.index("gen.hpp")
    assert by_output["CMakeFiles/libd.dir/a.cpp.o"].needs == (generated,)
    assert by_output["CMakeFiles/libd.dir/a.cpp.o"].distributable
    link = by_output["liblibd.so"]
    assert not link.distributable and not by_output["gen.hpp"].distributable
    assert {names[n] for n in link.needs} == {"CMakeFiles/libd.dir/a.cpp.o",
                                              "CMakeFiles/libd.dir/b.cpp.o"}
    assert [round(job.seconds, 3) for job in jobs] == [1.0, 4.0, 4.0, 1.0]


def test_more_machines_take_the_compiles_and_the_critical_path_is_the_floor(
        tmp_path: Path) -> None:
    recording = load_recording(_recording(tmp_path, packages=1))
    jobs = job_graph(recording)
    # one core: configure 1 + 0.5 overhead, generate 1, compiles 4 + 4, link 1, install 0.5
    assert simulate(jobs, machines=1, cores=1, workers=1) == 12.0
    # distributed, every compile goes to another machine: one other machine gains nothing,
    # two take both compiles at once
    assert simulate(jobs, machines=2, cores=1, workers=1) == 12.0
    assert simulate(jobs, machines=3, cores=1, workers=1) == 8.0
    rows, cap, fixed = predict(recording, machines=(1, 2, 4))
    assert fixed == 0.5  # wsbuild's own time after the last package
    assert cap == 8.5
    assert [r.seconds for r in rows] == [8.5, 8.5, 8.5]  # two cores already run both


def test_local_work_stays_on_the_first_machine(tmp_path: Path) -> None:
    recording = load_recording(_recording(tmp_path, packages=3))
    jobs = job_graph(recording)
    # a chain of three packages: only their compiles can go elsewhere
    one = simulate(jobs, machines=1, cores=1, workers=1)
    many = simulate(jobs, machines=16, cores=1, workers=1)
    assert one == 3 * 12.0
    assert many == 3 * 8.0


def _leaves(tmp_path: Path) -> PackageTimes:
    """tests/test_shard_build.py's workspace as a recording: base (2 s) and four leaves on it
    (10 s each), two workers."""
    rows = [{"name": "base", "seconds": 2.0, "depends": []}] + [
        {"name": leaf, "seconds": 10.0, "depends": ["base"]}
        for leaf in ("leaf_a", "leaf_b", "leaf_c", "leaf_d")]
    path = tmp_path / "leaves.json"
    path.write_text(json.dumps({"packages": rows, "workers": 2, "wall_seconds": 23.0,
                                "before_packages": 0.5, "after_packages": 0.5}))
    return PackageTimes.load(path)


def test_shards_are_played_out_as_wsbuild_runs_them(tmp_path: Path) -> None:
    times = _leaves(tmp_path)
    assert times.fixed == 1.0
    one = simulate_shards(times, 1)
    assert one.seconds == 22.0 and one.restored == 0  # base, then the leaves two by two
    two = simulate_shards(times, 2)
    # shard 1 builds base and two leaves; shard 2 restores base 3 s after it is done
    assert two.per_shard == (12.0, 15.0) and two.restored == 1 and two.built_again == 0
    assert two.bound == 12.0 and two.split_predicted == 15.0


def test_a_late_shard_costs_the_others_their_bounded_wait_only(tmp_path: Path) -> None:
    late = simulate_shards(_leaves(tmp_path), 2, delay={1: 60.0})
    # shard 2 waits 13 s for base, builds it, then its leaves: 13 + 2 + 10 = 25 s, one job
    # building everything (22 s) give or take a restore (3 s)
    assert late.per_shard[1] == 25.0 and late.built_again == 1
