"""Dependency-aware worker pool: run jobs in parallel, honour the failure policy, emit events."""

from __future__ import annotations

import heapq
import queue
import signal
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace

from wsbuild.build.process import REGISTRY, ProcessRegistry
from wsbuild.events import Emit, JobFinished, JobStarted
from wsbuild.workspace.model import BuildResult, Outcome

Job = Callable[[str], BuildResult]


def run_jobs(
    order: Sequence[str],
    dependencies: Mapping[str, set[str]],
    job: Job,
    *,
    workers: int,
    continue_on_error: bool,
    emit: Emit,
    registry: ProcessRegistry = REGISTRY,
) -> list[BuildResult]:
    """Run `job` for every name in `order` once its `dependencies` (within `order`) finished.

    Without `continue_on_error`, no job starts after a failure; jobs already running finish and
    the rest are reported as skipped. With it, only the dependents of a failed job are skipped.
    Ctrl-C (KeyboardInterrupt in the calling thread) terminates every child process group and
    reports running jobs as interrupted, then raises RunInterrupted.
    """
    names = list(order)
    members = set(names)
    waiting = {n: set(dependencies.get(n, set())) & members for n in names}
    results: dict[str, BuildResult] = {}
    done: queue.Queue[BuildResult] = queue.Queue()
    running: dict[str, float] = {}
    failed_any = False
    workers = max(1, workers)

    def worker(name: str) -> None:
        start = time.monotonic()
        try:
            result = job(name)
        except BaseException as exc:  # reported as a failure of this package, never lost
            import traceback

            result = BuildResult(
                name,
                Outcome.FAILED,
                message="internal error (a bug in wsbuild): "
                + "".join(traceback.format_exception_only(type(exc), exc)).strip(),
                reproduce="".join(traceback.format_exception(exc)),
            )
        if not result.seconds:
            result = replace(result, seconds=time.monotonic() - start)
        done.put(result)

    position = {name: index for index, name in enumerate(names)}
    users: dict[str, list[str]] = {name: [] for name in names}
    for name in names:
        for dep in waiting[name]:
            users[dep].append(name)
    # a heap of positions in `order`: among ready jobs, the earliest in order starts first
    ready = [position[name] for name in names if not waiting[name]]
    heapq.heapify(ready)

    def settle(result: BuildResult) -> None:
        results[result.package] = result
        emit(JobFinished(result))

    def skip_dependents(failed: str) -> None:
        stack = [failed]
        while stack:
            current = stack.pop()
            for user in users[current]:
                if user not in results:
                    settle(BuildResult(user, Outcome.SKIPPED,
                                       message=f"dependency failed: {current}"))
                    stack.append(user)

    try:
        while len(results) < len(names):
            if failed_any and not continue_on_error:
                for name in names:
                    if name not in results and name not in running:
                        settle(BuildResult(name, Outcome.SKIPPED,
                                           message="not started after an earlier failure"))
            else:
                while ready and len(running) < workers:
                    name = names[heapq.heappop(ready)]
                    if name in results:  # skipped meanwhile
                        continue
                    running[name] = time.monotonic()
                    emit(JobStarted(name))
                    threading.Thread(target=worker, args=(name,), daemon=True,
                                     name=f"wsbuild-{name}").start()
            if not running:
                if not ready and len(results) < len(names):
                    stalled = sorted(set(names) - set(results))
                    raise RuntimeError(f"scheduler stalled with {stalled} waiting (a bug)")
                continue
            result = done.get()
            running.pop(result.package, None)
            settle(result)
            if result.outcome in (Outcome.FINISHED, Outcome.UP_TO_DATE):
                for user in users[result.package]:
                    waiting[user].discard(result.package)
                    if not waiting[user] and user not in results:
                        heapq.heappush(ready, position[user])
            else:
                failed_any = True
                skip_dependents(result.package)
    except KeyboardInterrupt:
        # another Ctrl-C must not cut this short: process groups would be left running and
        # jobs abandoned half-way through swapping their install into place
        previous_handler = signal.signal(signal.SIGINT, signal.SIG_IGN)
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
                results[name] = BuildResult(name, outcome, message="interrupted")
        raise RunInterrupted([results[n] for n in names]) from None
    return [results[n] for n in names]


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C during a run; carries every job's result for the summary."""

    def __init__(self, results: list[BuildResult]) -> None:
        super().__init__()
        self.results = results
