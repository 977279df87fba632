"""engine/memory.py: the governor over real processes that hold known amounts of memory, on the
real scheduler and jobserver (the whole build: tests/test_memory_build.py)."""

from __future__ import annotations

import os
import sys
import threading
from pathlib import Path

from wsbuild.engine.jobs import JobResult, JobStarted, Outcome, StepStarted
from wsbuild.engine.jobserver import Jobserver
from wsbuild.engine.memory import PLENTIFUL_JOB, MemoryGovernor
from wsbuild.engine.memory_budget import MemoryBudget
from wsbuild.engine.memory_tree import read_tree
from wsbuild.engine.process import run_command
from wsbuild.engine.ready_queue import JobGraph
from wsbuild.engine.schedule import FailurePolicy, run_jobs
from wsbuild.events import JobFinished

M = 1024 * 1024
HOLD = 120 * M
#: holds HOLD bytes for a while, then ends
HOLDER = f"import time; block = b'x' * {HOLD}; time.sleep(1.0)"


def _run(names: list[str], budget: int, predictions: dict | None = None,
         tmp: Path | None = None, said: list[str] | None = None) -> tuple[list[object], object]:
    """Run one holder per job under a governor of `budget`; the events, and what it used."""
    jobserver = Jobserver(2)
    governor = MemoryGovernor(MemoryBudget(budget, 0, "test", 8 * 1024 * M), jobserver,
                              predictions or {}, warn=(said if said is not None else []).append,
                              read_free=lambda: None, workers=3).start()
    events: list[object] = []
    lock = threading.Lock()

    def emit(event: object) -> None:
        with lock:
            events.append(event)
        governor.hear(event)

    def job(name: str) -> JobResult:
        done = run_command([sys.executable, "-S", "-c", HOLDER], cwd=tmp or Path.cwd(),
                           env=dict(os.environ))
        return JobResult(name, Outcome.FINISHED if done.returncode == 0 else Outcome.FAILED)

    try:
        results = run_jobs(JobGraph.of(names, {}), job, workers=3, policy=FailurePolicy.STOP,
                           emit=emit, admit=governor.may_start)
    finally:
        use = governor.stop()
        jobserver.close()
    assert all(r.outcome is Outcome.FINISHED for r in results)
    return events, use


def _most_at_once(events: list[object]) -> int:
    running = most = 0
    for event in events:
        if isinstance(event, JobStarted):
            running += 1
            most = max(most, running)
        elif isinstance(event, JobFinished):
            running -= 1
    return most


def test_with_nothing_recorded_one_runs_and_is_measured_then_the_measures_admit(
        tmp_path: Path) -> None:
    here = sum(p.rss for p in read_tree(os.getpid()).values())
    # room for one holder beside this process, not for two
    events, use = _run(["a", "b", "c"], here + HOLD + HOLD // 2, tmp=tmp_path)
    assert _most_at_once(events) == 1
    assert use.peak <= use.budget.bytes
    assert all(use.packages[n].peak >= HOLD for n in "abc")
    assert sum(use.waited.values()) > 0
    # measured: room for two holders now admits two at a time (three workers)
    events, use = _run(["a", "b", "c"], here + 2 * HOLD + HOLD // 2, dict(use.packages),
                       tmp=tmp_path)
    assert _most_at_once(events) == 2
    assert use.peak <= use.budget.bytes


def test_with_plenty_of_memory_nothing_waits_to_be_measured_first(tmp_path: Path) -> None:
    """A budget that holds a heavy compile for every job the run can start at once (three
    workers' implicit slots and the jobserver's token): a cold build runs as without a budget;
    one job less of room, and the first package is measured alone."""
    slots = 3 + 1
    events, use = _run(["a", "b", "c"], PLENTIFUL_JOB * slots, tmp=tmp_path)
    assert _most_at_once(events) == 3 and not use.waited
    events, use = _run(["a", "b", "c"], PLENTIFUL_JOB * slots - 1, tmp=tmp_path)
    assert [type(e).__name__ for e in events[:2]] == ["JobStarted", "JobFinished"]
    assert sum(use.waited.values()) > 0


def test_what_cannot_fit_even_alone_runs_alone_is_never_stopped_and_is_said(
        tmp_path: Path) -> None:
    here = sum(p.rss for p in read_tree(os.getpid()).values())
    events, use = _run(["a", "b"], here + HOLD // 2, tmp=tmp_path)
    said: list[str] = []
    events, use = _run(["a", "b"], here + HOLD // 2, dict(use.packages), tmp=tmp_path,
                       said=said)
    assert _most_at_once(events) == 1  # each ran, alone, to its end
    assert sorted(use.alone) == ["a", "b"]
    assert any(text.startswith("a is predicted to need") and "it runs alone" in text
               for text in said), said


def test_the_jobserver_hands_out_only_what_is_released_and_takes_back_what_waits() -> None:
    jobserver = Jobserver(4)
    try:
        assert jobserver.circulating == 3
        assert jobserver.hold() == 3 and jobserver.circulating == 0
        assert jobserver.release(2) == 2 and jobserver.circulating == 2
        assert os.read(jobserver.read_fd, 1) == b"+"  # a make takes one
        assert jobserver.reclaim(2) == 1  # only the one still waiting comes back
        assert jobserver.circulating == 1
        os.write(jobserver.write_fd, b"+")  # the make's job ended
        assert jobserver.reclaim(1) == 1 and jobserver.circulating == 0
        assert jobserver.release(5) == 3
    finally:
        jobserver.close()


def test_steps_waiting_for_room_start_in_the_schedulers_order_and_never_wait_for_each_other(
        ) -> None:
    """Two packages reach a step that needs more than half the budget while a third holds it;
    the one the scheduler started later asks first. When the third ends, the step of the one
    started first starts (it came first in the scheduler's order: the critical path), then
    the other; neither waits for the other for ever."""
    from wsbuild.engine.jobs import StepStarted
    from wsbuild.engine.memory_records import PackageMemoryRecord, StepMemory

    here = sum(p.rss for p in read_tree(os.getpid()).values())
    compile_step = {"configure": StepMemory(10 * M), "build": StepMemory(330 * M, 300 * M, 4)}
    records = {name: PackageMemoryRecord(330 * M, compile_step) for name in ("a", "b", "c")}
    jobserver = Jobserver(2)
    governor = MemoryGovernor(MemoryBudget(here + 500 * M, 0, "test", 8 * 1024 * M), jobserver,
                              records, warn=lambda text: None, read_free=lambda: None).start()
    started: list[str] = []
    try:
        for name in ("c", "a", "b"):  # the scheduler's order
            governor.hear(JobStarted(name))
        governor.hear(StepStarted("c", "build"))  # c compiles: no room for another compile

        def step(name: str) -> None:
            governor.wait_for_step(name, "build", governor.hear)
            started.append(name)
            governor.hear(StepStarted(name, "build"))

        waiting_b = threading.Thread(target=step, args=("b",))
        waiting_b.start()
        while "b" not in governor._pending:  # noqa: SLF001 - b waits before a asks
            waiting_b.join(0.01)
        waiting_a = threading.Thread(target=step, args=("a",))
        waiting_a.start()
        waiting_a.join(0.5)
        assert started == []
        governor.hear(JobFinished(JobResult("c", Outcome.FINISHED)))
        waiting_a.join(10)
        assert started == ["a"]
        governor.hear(JobFinished(JobResult("a", Outcome.FINISHED)))
        waiting_b.join(10)
        assert started == ["a", "b"]
    finally:
        governor.stop()
        jobserver.close()


def test_a_step_starts_with_only_the_tokens_its_need_allows_still_out() -> None:
    """Tokens handed out while a package configured (its compiler checks are small jobs) must
    not reach the make or Ninja of its next step, which needs more: when a step is admitted,
    the tokens out come back to what it allows before its process can take them (the first
    compile of a build never measured runs alone; one measured at 300 MiB leaves room for
    none beside it here)."""
    from wsbuild.engine.memory_records import PackageMemoryRecord, StepMemory

    here = sum(p.rss for p in read_tree(os.getpid()).values())
    compile_step = {"configure": StepMemory(20 * M, 5 * M, 1),
                    "build": StepMemory(330 * M, 300 * M, 4)}
    for records in ({}, {"a": PackageMemoryRecord(330 * M, compile_step)}):
        jobserver = Jobserver(3)
        governor = MemoryGovernor(MemoryBudget(here + 500 * M, 0, "test", 8 * 1024 * M),
                                  jobserver, records, warn=lambda text: None,
                                  read_free=lambda: None, interval=3600).start()
        try:
            governor.hear(JobStarted("a"))
            governor.wait_for_step("a", "configure", governor.hear)
            governor.hear(StepStarted("a", "configure"))
            # what a tick hands out while the configure's checks leave room: both tokens
            assert jobserver.release(2) == 2 and jobserver.circulating == 2
            governor.wait_for_step("a", "build", governor.hear)
            assert jobserver.circulating == 0, records
        finally:
            governor.stop()
            jobserver.close()
