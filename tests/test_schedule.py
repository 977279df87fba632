"""The worker pool: dependency order, parallelism, failure policy."""

from __future__ import annotations

import threading
import time

from wsbuild.events import JobFinished, JobStarted
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.engine.ready_queue import JobGraph
from wsbuild.engine.schedule import FailurePolicy, run_jobs

DEPS = {"a": set(), "b": {"a"}, "c": {"a"}, "d": {"b", "c"}, "e": set()}
ORDER = ["a", "e", "b", "c", "d"]


def test_dependencies_finish_before_dependents_start() -> None:
    finished: list[str] = []
    lock = threading.Lock()

    def job(name: str) -> JobResult:
        with lock:
            assert DEPS[name] <= set(finished), f"{name} started before its dependencies"
        time.sleep(0.01)
        with lock:
            finished.append(name)
        return JobResult(name, Outcome.FINISHED)

    results = run_jobs(JobGraph.of(ORDER, DEPS), job, workers=3, policy=FailurePolicy.STOP,
                       emit=lambda e: None)
    assert [r.package for r in results] == ORDER
    assert all(r.outcome is Outcome.FINISHED for r in results)


def test_workers_bound_parallelism() -> None:
    running = 0
    peak = 0
    lock = threading.Lock()

    def job(name: str) -> JobResult:
        nonlocal running, peak
        with lock:
            running += 1
            peak = max(peak, running)
        time.sleep(0.05)
        with lock:
            running -= 1
        return JobResult(name, Outcome.FINISHED)

    names = [f"p{i}" for i in range(6)]
    run_jobs(JobGraph.of(names, {}), job, workers=2, policy=FailurePolicy.STOP,
             emit=lambda e: None)
    assert peak == 2


def _failing_b(name: str) -> JobResult:
    if name == "b":
        return JobResult(name, Outcome.FAILED, message="boom")
    time.sleep(0.05 if name == "e" else 0)
    return JobResult(name, Outcome.FINISHED)


def test_default_policy_starts_nothing_after_a_failure() -> None:
    events: list[object] = []
    results = {r.package: r.outcome for r in run_jobs(
        JobGraph.of(["a", "b", "c", "d"], DEPS), _failing_b, workers=1, policy=FailurePolicy.STOP,
        emit=events.append)}
    assert results == {"a": Outcome.FINISHED, "b": Outcome.FAILED, "c": Outcome.SKIPPED,
                       "d": Outcome.SKIPPED}
    started = [e.package for e in events if isinstance(e, JobStarted)]
    assert started == ["a", "b"]
    assert sum(isinstance(e, JobFinished) for e in events) == 4


def test_continue_on_error_skips_only_dependents() -> None:
    results = {r.package: r for r in run_jobs(
        JobGraph.of(ORDER, DEPS), _failing_b, workers=2, policy=FailurePolicy.SKIP_DEPENDENTS,
        emit=lambda e: None)}
    assert results["c"].outcome is Outcome.FINISHED
    assert results["e"].outcome is Outcome.FINISHED
    assert results["d"].outcome is Outcome.SKIPPED
    assert "b" in results["d"].message


def test_a_crashing_job_is_a_failure_not_a_hang() -> None:
    def job(name: str) -> JobResult:
        raise RuntimeError("bug")

    results = run_jobs(JobGraph.of(["a"], {}), job, workers=1, policy=FailurePolicy.STOP,
                       emit=lambda e: None)
    assert results[0].outcome is Outcome.FAILED
    assert "bug in wsbuild" in results[0].message


def test_a_job_waiting_for_another_machine_takes_no_worker() -> None:
    # one worker; "remote" waits until "local" has run (a shard's package of another shard,
    # waited for while the shard builds its own): were it to take the worker, "local" could
    # only start after its wait ran out
    local_ran = threading.Event()
    seen: dict[str, bool] = {}

    def job(name: str) -> JobResult:
        if name == "remote":
            seen["local ran while remote waited"] = local_ran.wait(timeout=30)
        else:
            local_ran.set()
        return JobResult(name, Outcome.FINISHED)

    graph = JobGraph.of(["remote", "local"], {})
    results = run_jobs(graph, job, workers=1, policy=FailurePolicy.STOP, emit=lambda e: None,
                       weights={"remote": 10.0, "local": 1.0}, waiting={"remote"})
    assert seen == {"local ran while remote waited": True}
    assert all(r.outcome is Outcome.FINISHED for r in results)


def test_a_job_held_back_by_admission_is_overtaken_by_none_and_alone_it_starts() -> None:
    started: list[str] = []
    asked: list[tuple[str, tuple[str, ...]]] = []
    running: set[str] = set()
    lock = threading.Lock()

    def admit(name: str) -> bool:
        with lock:
            asked.append((name, tuple(sorted(running))))
            # "big" fits beside nothing; the others beside anything
            return name != "big" or not running

    def job(name: str) -> JobResult:
        with lock:
            started.append(name)
            running.add(name)
        time.sleep(0.05)
        with lock:
            running.discard(name)
        return JobResult(name, Outcome.FINISHED)

    # "first" starts first; then "big" (the most work behind it) waits for room while
    # "small" could start at once: it does not overtake "big"
    graph = JobGraph.of(["first", "big", "small", "tail"], {"tail": {"big"}})
    run_jobs(graph, job, workers=3, policy=FailurePolicy.STOP, emit=lambda e: None,
             weights={"first": 10, "big": 5, "small": 1, "tail": 1}, admit=admit)
    assert started == ["first", "big", "small", "tail"]
    assert ("big", ("first",)) in asked and ("big", ()) in asked
