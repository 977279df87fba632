"""Dependency-aware worker pool: run jobs in parallel, honour the failure policy, emit events.

Which job starts next is ready_queue.py's answer (dependencies settled, critical path first,
then the given order), the same a plan's start order is made of. Weights are each package's
duration in the last recorded build (kept in `build/.wsbuild/durations.json`, see
`timings.py`), or an estimate from its number of interface and source files when none is
recorded. `JobGraph.critical_path()` gives the chain that bounds the run from below.
"""

from __future__ import annotations

import queue
import signal
import threading
import time
from collections.abc import Callable, Collection, Mapping
from dataclasses import replace
from enum import Enum

from wsbuild.engine.process import (
    REGISTRY,
    ProcessRegistry,
    adopt_orphans,
    start_processes_for,
)
from wsbuild.engine.jobs import JobEvent, JobFinished, JobStarted
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.engine.ready_queue import JobGraph, ReadyQueue

Job = Callable[[str], JobResult]
#: may a job start now (besides its dependencies and a free worker)? the memory governor's
#: answer (engine/memory.py); asked again every ADMISSION_POLL seconds while it says no
Admission = Callable[[str], bool]
ADMISSION_POLL = 0.05


class FailurePolicy(Enum):
    """What a failed job means for the others."""

    #: no job starts after a failure; running ones finish, the rest are skipped
    STOP = "stop"
    #: the jobs depending on the failed one are skipped, the others go on (--continue-on-error)
    SKIP_DEPENDENTS = "skip dependents"
    #: every other job still runs (tests of a package whose dependency's tests failed)
    CONTINUE = "continue"


def run_jobs(
    jobs: JobGraph,
    job: Job,
    *,
    workers: int,
    policy: FailurePolicy,
    emit: Callable[[JobEvent], None],
    registry: ProcessRegistry = REGISTRY,
    weights: Mapping[str, float] | None = None,
    waiting: Collection[str] = (),
    admit: Admission | None = None,
) -> list[JobResult]:
    """Run `job` for every job of `jobs` once its dependencies finished, in the order of a
    `ReadyQueue` under `weights` (the most remaining work first). The jobs named in `waiting`
    mostly wait for another machine (a shard's packages of other shards, builder/shards/run.py):
    they start as soon as they are ready and take no worker. With `admit`, the next job in
    that order starts only when `admit` says it may (memory): none overtakes it meanwhile.

    A failed job (outcome FAILED) affects the others as `policy` says.
    Ctrl-C (KeyboardInterrupt in the calling thread) terminates every child process group and
    every descendant of this process (`ProcessRegistry.terminate_all`; the calling process
    becomes their child subreaper, so one that left its parent is still found), reports
    running jobs as interrupted, then raises RunInterrupted. A second Ctrl-C while they stop
    kills what is left at once.

    Over 80 lines because the loop, its Ctrl-C path and the closures they share hold one
    run's state (waiting, ready, running, results): split, they would pass it all around.
    """
    names = list(jobs.order)
    ready = ReadyQueue(jobs, weights)
    results: dict[str, JobResult] = {}
    done: queue.Queue[JobResult] = queue.Queue()
    running: dict[str, float] = {}
    failed_any = False
    workers = max(1, workers)
    adopt_orphans()

    def worker(name: str) -> None:
        start = time.monotonic()
        start_processes_for(name)
        try:
            result = job(name)
        except BaseException as exc:  # reported as a failure of this package, never lost
            import traceback

            result = JobResult(
                name,
                Outcome.FAILED,
                message="internal error (a bug in wsbuild): "
                + "".join(traceback.format_exception_only(type(exc), exc)).strip(),
                reproduce="".join(traceback.format_exception(exc)),
            )
        if not result.seconds:
            result = replace(result, seconds=time.monotonic() - start)
        done.put(result)

    def settle(result: JobResult) -> None:
        results[result.package] = result
        emit(JobFinished(result))
        succeeded = result.outcome in (Outcome.FINISHED, Outcome.UP_TO_DATE)
        ready.settle(result.package, release=succeeded or policy is FailurePolicy.CONTINUE)

    def skip_dependents(failed: str) -> None:
        stack = [failed]
        while stack:
            current = stack.pop()
            for user in jobs.dependents[current]:
                if user not in results:
                    settle(JobResult(user, Outcome.SKIPPED,
                                       message=f"dependency failed: {current}"))
                    stack.append(user)

    try:
        while len(results) < len(names):
            if failed_any and policy is FailurePolicy.STOP:
                for name in names:
                    if name not in results and name not in running:
                        settle(JobResult(name, Outcome.SKIPPED,
                                           message="not started after an earlier failure"))
            else:
                while (name := _next_job(ready, running, workers, waiting, admit)) is not None:
                    running[name] = time.monotonic()
                    emit(JobStarted(name))
                    threading.Thread(target=worker, args=(name,), daemon=True,
                                     name=f"wsbuild-{name}").start()
            if not running:
                if not ready.has_ready() and len(results) < len(names):
                    stalled = sorted(set(names) - set(results))
                    raise RuntimeError(f"scheduler stalled with {stalled} waiting (a bug)")
                continue
            try:
                # a job held back for memory is asked about again soon
                result = done.get(timeout=ADMISSION_POLL if admit is not None
                                  and ready.has_ready() else None)
            except queue.Empty:
                continue
            running.pop(result.package, None)
            settle(result)
            if result.outcome not in (Outcome.FINISHED, Outcome.UP_TO_DATE):
                failed_any = True
                if policy is FailurePolicy.SKIP_DEPENDENTS:
                    skip_dependents(result.package)
    except KeyboardInterrupt:
        # another Ctrl-C must not cut this short (jobs would be abandoned half-way through
        # swapping their install into place): it only stops the waiting for SIGTERM to work
        previous_handler = signal.signal(signal.SIGINT, lambda _sig, _frame: registry.hurry())
        try:
            registry.terminate_all()
            deadline = time.monotonic() + 10
            while running and time.monotonic() < deadline:
                try:
                    result = done.get(timeout=max(0.1, deadline - time.monotonic()))
                except queue.Empty:
                    break
                running.pop(result.package, None)
                results[result.package] = replace(result, outcome=Outcome.INTERRUPTED) \
                    if result.outcome is Outcome.FAILED else result
        finally:
            signal.signal(signal.SIGINT, previous_handler)
        for name in names:
            if name not in results:
                outcome = Outcome.INTERRUPTED if name in running else Outcome.SKIPPED
                results[name] = JobResult(name, outcome, message="interrupted")
        raise RunInterrupted([results[n] for n in names]) from None
    return [results[n] for n in names]


def _next_job(ready: ReadyQueue, running: Collection[str], workers: int,
              waiting: Collection[str], admit: Admission | None = None) -> str | None:
    """The next job to start: any ready one while a worker is free, else one that waits for
    another machine (it takes no worker). With `admit`, the first in the queue's order that
    takes a worker starts only when admitted; while it is not, none after it starts. With no
    job running, it starts regardless: a job that cannot fit beside others runs alone."""
    busy = sum(1 for name in running if name not in waiting)
    if busy < workers:
        if admit is None:
            return ready.pop()
        asked: list[str] = []

        def accept(name: str) -> bool:
            if name in waiting:
                return True
            if asked:
                return False
            asked.append(name)
            return admit(name) or not busy

        return ready.pop(accept)
    return ready.pop(lambda name: name in waiting) if waiting else None


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C during a run; carries every job's result for the summary."""

    def __init__(self, results: list[JobResult]) -> None:
        super().__init__()
        self.results = results
