"""The admission rule: may a package start, and how many jobserver tokens may circulate, so
that what runs plus what it is predicted to take next fits the memory budget. Pure logic: the
memory governor (engine/memory.py) hands in what it measured and predicts.

What is committed (`committed`) is what the tree holds now, with each running job raised to
its package's predicted job peak (it may still grow to it), each package between its jobs
holding room for its next one (make's or Ninja's implicit slot), and each token that
circulates unused holding room for the largest job a running make or Ninja could start with
it. Tokens go to whoever asks first (one FIFO for every package): so a free token is worth the
largest job of any package that could take it.

- A token is handed out when the committed memory plus one more such job fits the budget,
  while no make or Ninja of a package without a prediction runs (its first job is measured
  alone: `unmeasured`), and while the live guard sees enough free memory (`low` is False).
- A package starts when the committed memory plus its predicted peak (of a job, or of a step
  with no make or Ninja: configure, a Python build) fits, or when nothing runs: a package
  that cannot fit even alone then runs alone (`alone`). A package without a prediction
  starts with the largest prediction known; while none is known, only one such package runs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Prediction:
    """What one package needs, in bytes (None: not known)."""

    #: the peak of one job under its make or Ninja (a compile, a link)
    job: int | None = None
    #: the package's largest need: of any step's processes (configure, setup.py) or job
    #: (None: nothing known of it yet)
    step: int | None = None

    @property
    def slot(self) -> int | None:
        """What the package's one job (its implicit slot) may take: its larger peak."""
        known = [v for v in (self.job, self.step) if v is not None]
        return max(known) if known else None


@dataclass(frozen=True, slots=True)
class Running:
    """A running package as measured now, with what is predicted of it."""

    name: str
    #: its processes' resident memory now
    rss: int = 0
    #: each of its jobs' resident memory now
    jobs: tuple[int, ...] = ()
    #: a make or Ninja of its runs (its jobs may take tokens)
    driving: bool = False
    prediction: Prediction = Prediction()


@dataclass(frozen=True, slots=True)
class MemoryState:
    """What the governor knows at one moment."""

    budget: int
    #: the build's process tree now (wsbuild's own process included)
    total: int
    running: tuple[Running, ...]
    #: tokens in circulation (in the FIFO or held by a make or Ninja)
    tokens_out: int
    #: the largest prediction known (of any package), for a package without one
    fallback: int | None
    #: free memory is below the margin (the live guard)
    low: bool = False


def _job(package: Running, fallback: int | None) -> int:
    """The job peak a package is predicted to reach: its own, else the fallback; never below
    what its running jobs hold now."""
    predicted = package.prediction.job
    if predicted is None:
        predicted = fallback or 0
    return max([predicted, *package.jobs])


def _own(package: Running, fallback: int | None) -> tuple[int, int]:
    """What a running package commits (bytes), and how many tokens its jobs hold: a make or
    Ninja runs one job on its implicit slot, each further job holds a token."""
    job = _job(package, fallback)
    if package.driving and package.jobs:
        overhead = package.rss - sum(package.jobs)
        return overhead + sum(max(rss, job) for rss in package.jobs), len(package.jobs) - 1
    if package.driving:  # between jobs: the implicit slot's next one
        return package.rss + job, 0
    slot = package.prediction.slot
    return max(package.rss, job if slot is None else slot), 0


def _token_job(state: MemoryState) -> int:
    """What a free token may start: the largest job of a running make or Ninja."""
    return max((_job(p, state.fallback) for p in state.running if p.driving), default=0)


def committed(state: MemoryState) -> tuple[int, int]:
    """The memory committed now, and the tokens in circulation that no job holds."""
    outside = state.total - sum(p.rss for p in state.running)
    total, held = max(0, outside), 0
    for package in state.running:
        own, tokens = _own(package, state.fallback)
        total += own
        held += tokens
    free = max(0, state.tokens_out - held)
    return total + free * _token_job(state), free


def unmeasured(state: MemoryState) -> list[str]:
    """Running packages whose make or Ninja runs before any job of theirs was measured."""
    return [p.name for p in state.running if p.driving and p.prediction.job is None]


def tokens_wanted(state: MemoryState, capacity: int) -> int:
    """How many tokens should circulate (at most `capacity`). Fewer than circulate means:
    take back the free ones (those make and Ninja return are taken back as they come)."""
    memory, free = committed(state)
    held = state.tokens_out - free
    job = _token_job(state)
    if not any(p.driving for p in state.running) or state.low or unmeasured(state):
        return held
    if memory > state.budget:
        excess = -(-(memory - state.budget) // max(1, job))
        return max(held, state.tokens_out - excess)
    wanted = state.tokens_out
    while wanted < capacity and memory + job <= state.budget:
        wanted += 1
        memory += job
    return wanted


@dataclass(frozen=True, slots=True)
class Verdict:
    """May a package start now; when not, why; `alone`: it cannot fit even alone."""

    start: bool
    why: str = ""
    alone: bool = False


def may_start(state: MemoryState, prediction: Prediction) -> Verdict:
    """Whether a package predicted to need `prediction` may start now (see the module)."""
    slot = prediction.slot
    if slot is None:
        slot = state.fallback
    outside = state.total - sum(p.rss for p in state.running)
    alone = slot is not None and max(0, outside) + slot > state.budget
    if not state.running:
        return Verdict(True, alone=alone)
    if state.low:
        return Verdict(False, "free memory is below the margin")
    if alone:
        return Verdict(False, "it does not fit beside others", alone=True)
    if slot is None:
        waiting = [p.name for p in state.running if p.prediction.step is None]
        if waiting:
            return Verdict(False, f"nothing is known yet: {waiting[0]} is measured first")
        slot = 0
    memory, _ = committed(state)
    if memory + slot > state.budget:
        return Verdict(False, "what runs leaves no room")
    return Verdict(True)


def over_budget(state: MemoryState) -> bool:
    return committed(state)[0] > state.budget


__all__: Sequence[str] = ("MemoryState", "Prediction", "Running", "Verdict", "committed",
                          "may_start", "over_budget", "tokens_wanted", "unmeasured")
