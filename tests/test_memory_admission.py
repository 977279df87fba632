"""engine/memory_admission.py: the rule that admits packages, steps and jobserver tokens by
what runs and what is predicted (fake numbers: the rule is pure logic)."""

from __future__ import annotations

from wsbuild.engine.memory_admission import (
    MemoryState,
    Need,
    Running,
    committed,
    may_start,
    tokens_wanted,
)

M = 1024 * 1024
COMPILING = Need(job=300 * M, start=320 * M, known=True)


def state(*running: Running, budget: int = 1000 * M, total: int | None = None,
          tokens_out: int = 0, fallback: int | None = None, low: bool = False) -> MemoryState:
    """A build whose own process holds 50 MiB beside its packages."""
    held = sum(p.rss for p in running)
    return MemoryState(budget, 50 * M + held if total is None else total, running, tokens_out,
                       fallback, low)


def compiling(name: str, *jobs: int, need: Need = COMPILING) -> Running:
    """A package whose make or Ninja (20 MiB with its cmake --build) runs `jobs`."""
    return Running(name, 20 * M + sum(jobs), tuple(jobs), True, need)


def test_a_token_goes_out_only_while_one_more_predicted_job_fits() -> None:
    # 50 + 20 + 300 (its implicit job, raised to the prediction) = 370: 2 more jobs fit in 1000
    assert tokens_wanted(state(compiling("a", 10 * M)), capacity=5) == 2
    # one job's room left
    assert tokens_wanted(state(compiling("a", 10 * M), budget=700 * M), capacity=5) == 1
    # the CPUs bound it too
    assert tokens_wanted(state(compiling("a", 10 * M)), capacity=1) == 1
    # a job that grew past its prediction counts as it is
    grown = compiling("a", 640 * M)
    assert tokens_wanted(state(grown), capacity=5) == 0


def test_free_tokens_are_taken_back_when_what_runs_grew_past_the_budget() -> None:
    # two tokens out, one held by the second job: the free one is worth a 300 MiB job
    running = compiling("a", 300 * M, 300 * M)
    assert committed(state(running, tokens_out=2)) == (50 * M + 620 * M + 300 * M, 1)
    assert tokens_wanted(state(running, tokens_out=2), capacity=5) == 2  # 970 fits in 1000
    assert tokens_wanted(state(running, tokens_out=2, budget=900 * M), capacity=5) == 1
    # a token held by a job is never asked back: it returns when the job ends
    assert tokens_wanted(state(running, tokens_out=1, budget=500 * M), capacity=5) == 1


def test_no_token_while_a_step_without_a_prediction_compiles_or_free_memory_is_low() -> None:
    unknown = compiling("new", 10 * M, need=Need(known=False))
    assert tokens_wanted(state(unknown, tokens_out=1), capacity=5) == 0
    assert tokens_wanted(state(compiling("a", 10 * M), low=True, tokens_out=1), capacity=5) == 0
    # no make or Ninja runs: the tokens come back (none is worth anything to a configure)
    configuring = Running("a", 40 * M, need=Need(300 * M, 60 * M, True))
    assert tokens_wanted(state(configuring, tokens_out=2), capacity=5) == 0


def test_a_package_starts_when_what_it_needs_fits_beside_what_runs() -> None:
    running = state(compiling("a", 200 * M))
    assert may_start(running, "b", Need(300 * M, 300 * M, True)).start
    assert not may_start(running, "b", Need(700 * M, 700 * M, True)).start
    # a token out unused could be taken by b's larger jobs: worth b's job, not a's
    small = Running("a", 30 * M, (10 * M,), True, Need(10 * M, 20 * M, True))
    b = Need(400 * M, 450 * M, True)
    assert may_start(state(small, budget=900 * M), "b", b).start  # 50 + 30 + 450
    assert not may_start(state(small, tokens_out=1, budget=900 * M), "b", b).start  # + 400


def test_what_cannot_fit_beside_others_runs_alone_and_says_so() -> None:
    huge = Need(2000 * M, 2000 * M, True)
    verdict = may_start(state(compiling("a", 10 * M)), "big", huge)
    assert not verdict.start and verdict.alone
    verdict = may_start(state(), "big", huge)
    assert verdict.start and verdict.alone
    # nothing runs: anything starts, even when free memory is low (it would wait forever)
    assert may_start(state(low=True), "b", COMPILING).start
    assert not may_start(state(compiling("a"), low=True), "b", Need(1, 1, True)).start


def test_with_nothing_known_one_package_is_measured_first_then_the_largest_known_stands_in(
        ) -> None:
    first = Running("first", 30 * M, need=Need(known=False))
    verdict = may_start(state(first), "second", Need())
    assert not verdict.start and "first is measured first" in verdict.why
    # once something is known (a package finished), an unknown one needs that much
    assert may_start(state(first, fallback=300 * M), "second", Need()).start
    assert not may_start(state(first, fallback=900 * M), "second", Need()).start


def test_a_step_holds_room_for_what_it_needs_in_place_of_what_its_package_holds() -> None:
    # b configured (60 MiB) and now wants to compile: its entry is replaced by its need
    between = Running("b", 0, need=Need(300 * M, 60 * M, True))
    assert may_start(state(compiling("a", 300 * M), between, budget=900 * M), "b",
                     COMPILING).start  # 50 + 320 + 320
    assert not may_start(state(compiling("a", 300 * M, 300 * M), between, budget=900 * M), "b",
                         COMPILING).start  # 50 + 620 + 320


def test_one_unmeasured_make_or_ninja_at_a_time() -> None:
    # a's make runs its first job, never measured: b (never recorded either) waits for it
    measuring = Running("a", 60 * M, (40 * M,), True, Need(known=False), measuring=True)
    verdict = may_start(state(measuring, Running("b"), fallback=100 * M), "b", Need())
    assert not verdict.start and "first job of a is measured first" in verdict.why
    # a's first job measured: b's step needs the largest known and fits
    measured = Running("a", 60 * M, (40 * M,), True, Need(job=150 * M, known=False))
    assert may_start(state(measured, Running("b"), fallback=150 * M), "b", Need()).start
    # a recorded package's step does not wait for it
    assert may_start(state(measuring, fallback=100 * M), "c", COMPILING).start
