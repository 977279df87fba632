"""builder/shards/split.py: the split of a build across the jobs of a CI matrix (which shard builds
which package, the predicted times, each shard's waits) and `wsbuild plan --shards N`; pure
logic on graphs and weights, then the verb on a tiny real workspace."""

from __future__ import annotations

import json
import os
import random
from collections.abc import Callable
from pathlib import Path

import pytest

from conftest import run_wsbuild
from wsbuild.builder.shards.split import (
    ShardSpec,
    calibrated_weights,
    graph_digest,
    parse_shard,
    shard_run_id,
    split_packages,
)
from wsbuild.engine.ready_queue import JobGraph
from wsbuild.errors import WsbuildError

#: the workspace of tests/test_shard_build.py: base, and four leaves on it
LEAVES = JobGraph.of(["base", "leaf_a", "leaf_b", "leaf_c", "leaf_d"],
                     {leaf: {"base"} for leaf in ("leaf_a", "leaf_b", "leaf_c", "leaf_d")})
TIMES = {"base": 2.0, "leaf_a": 10.0, "leaf_b": 10.0, "leaf_c": 10.0, "leaf_d": 10.0}


def test_shard_arguments_are_checked_in_one_line() -> None:
    assert parse_shard("2/3") == ShardSpec(2, 3)
    for bad in ("0/3", "4/3", "2", "a/b", "-1/2", "1/0"):
        with pytest.raises(WsbuildError, match=r"--shard takes K/N with 1 <= K <= N"):
            parse_shard(bad)


def test_the_ci_run_comes_from_the_ci_systems_variables() -> None:
    assert shard_run_id({"GITHUB_RUN_ID": "7", "GITHUB_RUN_ATTEMPT": "2"}) == "github-7"
    assert shard_run_id({"CI_PIPELINE_ID": "9"}) == "gitlab-9"
    assert shard_run_id({"WSBUILD_SHARD_RUN": "x", "CI_PIPELINE_ID": "9"}) == "x"
    assert shard_run_id({}) == ""


def test_the_split_of_the_shard_build_tests_and_its_waits() -> None:
    split = split_packages(LEAVES, TIMES, 2, 2)
    assert split.packages(1) == ("base", "leaf_a", "leaf_b")
    assert split.packages(2) == ("leaf_c", "leaf_d")
    assert split.one_machine == 22.0 and split.shard_seconds(1) == 12.0
    # base arrives at 2 + 3 s; the wait stops where building base and a leaf here would end
    # after one job building everything (22 − 12 + 3 s)
    needed = split.needed(2, {name: LEAVES.dependencies[name] for name in LEAVES.order})
    assert needed == ("base", "leaf_c", "leaf_d")
    assert split.waits(2, needed) == {"base": 13.0}
    three = split_packages(LEAVES, TIMES, 3, 2)
    assert [three.packages(k) for k in (1, 2, 3)] == [("base", "leaf_a", "leaf_b"),
                                                     ("leaf_c",), ("leaf_d",)]


def test_a_chain_stays_in_one_shard_when_splitting_it_would_not_help() -> None:
    chain = JobGraph.of(["a", "b", "c", "d"], {"b": {"a"}, "c": {"b"}, "d": {"c"}})
    split = split_packages(chain, dict.fromkeys("abcd", 5.0), 3, 2)
    assert set(split.assignment.values()) == {1}
    assert split.predicted == 20.0 == split.bound


def test_independent_work_is_balanced() -> None:
    names = [f"p{i}" for i in range(8)]
    split = split_packages(JobGraph.of(names, {}), dict.fromkeys(names, 4.0), 4, 1)
    assert sorted(len(split.packages(k)) for k in range(1, 5)) == [2, 2, 2, 2]
    assert split.predicted == 8.0 == split.bound


def _random_graph(seed: int, count: int = 120) -> tuple[JobGraph, dict[str, float]]:
    rng = random.Random(seed)
    names = [f"p{i:03d}" for i in range(count)]
    deps = {name: {names[int(i * rng.random() ** 0.5)] for _ in range(rng.randint(0, 3))}
            for i, name in enumerate(names) if i}
    return JobGraph.of(names, deps), {n: rng.lognormvariate(1.0, 0.8) for n in names}


def test_every_job_computes_the_same_split_from_the_same_workspace() -> None:
    jobs, weights = _random_graph(1)
    first = split_packages(jobs, weights, 4, 2)
    again = split_packages(JobGraph.of(list(jobs.order), jobs.dependencies), dict(weights), 4, 2)
    assert again.assignment == first.assignment and again.digest == first.digest
    # the same assignment given (a split taken from another shard) gives the same schedule
    taken = split_packages(jobs, weights, 4, 2, assignment=first.assignment)
    assert taken.finish == first.finish
    other = split_packages(jobs, {**weights, "p050": weights["p050"] + 30}, 4, 2)
    assert other.digest != first.digest


def test_no_wait_outlasts_one_job_building_everything() -> None:
    jobs, weights = _random_graph(2)
    split = split_packages(jobs, weights, 4, 2)
    closure: dict[str, set[str]] = {}
    for name in jobs.order:
        closure[name] = set(jobs.dependencies[name]).union(
            *(closure[d] for d in jobs.dependencies[name]))
    for index in range(1, 5):
        needed = split.needed(index, closure)
        remaining = jobs.subset(needed).remaining_work(weights)
        waits = split.waits(index, needed)
        assert set(waits) == set(needed) - set(split.packages(index))
        for name, seconds in waits.items():
            assert 0 <= seconds <= max(0.0, split.one_machine - remaining[name]
                                       + split.transfer) + 1e-6


def test_a_shards_scheduler_ranks_its_packages_by_their_work_in_the_whole_split() -> None:
    # leaf_x has nothing behind it in shard 1, but a long chain behind it in shard 2
    jobs = JobGraph.of(["x", "y", "z"], {"z": {"x"}})
    split = split_packages(jobs, {"x": 1.0, "y": 5.0, "z": 20.0}, 2, 1,
                           assignment={"x": 1, "y": 1, "z": 2})
    subset = jobs.subset(["x", "y"])
    assert subset.remaining_work(split.priorities(["x", "y"])) == {"x": 21.0, "y": 5.0}


def test_unknown_packages_weigh_their_estimate_scaled_to_the_recorded_ones() -> None:
    weights, estimated = calibrated_weights(["a", "b", "c"], {"a": 10.0, "b": 30.0},
                                            {"a": 1.0, "b": 2.0, "c": 3.0})
    assert estimated == frozenset({"c"})
    assert weights == {"a": 10.0, "b": 30.0, "c": 45.0}  # median of 10× and 15×
    assert calibrated_weights(["c"], {}, {"c": 3.0})[0] == {"c": 3.0}


def test_the_graph_digest_tells_another_workspace() -> None:
    base = graph_digest(LEAVES)
    assert graph_digest(JobGraph.of(list(LEAVES.order), LEAVES.dependencies)) == base
    assert graph_digest(JobGraph.of([*LEAVES.order, "leaf_e"], LEAVES.dependencies)) != base
    assert graph_digest(JobGraph.of(list(LEAVES.order), {"leaf_a": {"leaf_b"}})) != base


def test_plan_prints_the_matrix_as_json_and_as_text(
        make_workspace: Callable[..., Path]) -> None:
    ws = make_workspace({"pa": ("ament_python", []), "pb": ("ament_python", ["pa"]),
                         "pc": ("cmake", []), "pd": ("cmake", [])})
    done = run_wsbuild("plan", "--shards", "2", "--json", "--parallel-workers", "1", cwd=ws)
    assert done.returncode == 0, done.stderr
    plan = json.loads(done.stdout)
    include = plan["matrix"]["include"]
    assert [entry["shard"] for entry in include] == ["1/2", "2/2"]
    names = [name for entry in include for name in entry["packages"]]
    assert sorted(names) == ["pa", "pb", "pc", "pd"]
    assert plan["estimated"] == ["pa", "pb", "pc", "pd"]  # never built: estimates
    assert plan["predicted_seconds"] >= plan["bound_seconds"]
    text = run_wsbuild("plan", "--shards", "2", "--parallel-workers", "1", cwd=ws)
    assert text.returncode == 0 and text.stdout.startswith("4 packages in 2 shards of 1 worker")
    for entry in include:
        assert f"shard {entry['shard']}: " in text.stdout


@pytest.mark.parametrize(("argv", "says"), [
    (["plan", "--shards", "0"], "--shards takes a number of CI jobs (1 or more), got '0'"),
    (["build", "--shard", "3/2"], "--shard takes K/N with 1 <= K <= N, got '3/2'"),
    (["build", "--shard", "1/2"], "--shard 1/2 needs a build cache on a server the jobs share"),
    (["build", "--shard", "1/2", "--cache", "http://127.0.0.1:9/", "--cache-read-only"],
     "--shard 1/2 needs a build cache on a server the jobs share"),
    (["test", "--shard", "2"], "--shard takes K/N with 1 <= K <= N, got '2'"),
    (["build", "--assemble", "x"], "--assemble takes a number of CI jobs (1 or more), got 'x'"),
    (["build", "--assemble", "2"], "--assemble 2 needs the build cache server the shards shared"),
    (["build", "--assemble", "2", "--shard", "1/2", "--cache", "http://127.0.0.1:9/"],
     "--assemble and --shard exclude each other"),
])
def test_bad_shard_arguments_are_one_line_and_exit_2(
        make_workspace: Callable[..., Path], argv: list[str], says: str) -> None:
    ws = make_workspace({"pa": ("ament_python", [])})
    done = run_wsbuild(*argv, cwd=ws, env={k: v for k, v in os.environ.items()
                                           if k != "WSBUILD_CACHE"})
    assert done.returncode == 2, done.stdout + done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and says in lines[0], done.stderr
