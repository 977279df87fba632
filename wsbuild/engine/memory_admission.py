"""The admission rule: may a package start, may one of its steps start, and how many
jobserver tokens may circulate, so that what runs plus what it is predicted to take next fits
the memory budget. Pure logic: the memory governor (engine/memory.py) hands in what it
measured and predicts.

What is committed (`committed`) is what the build's process tree holds now, with each running
job raised to its step's predicted job peak (it may still grow to it), each package between
its jobs holding room for its next one (the implicit slot of its make or Ninja), each package
holding at least what it is predicted to need (`Need.start`: its step's, or what it needs
ahead), a step waiting to start holding room for what it needs, and each token that
circulates unused holding room for the largest job a running package could start with it:
tokens go to whichever make or Ninja asks first (one FIFO for every package).

- A token is handed out when the committed memory plus one more such job fits the budget,
  while no make or Ninja of a step without a prediction runs (its first job is measured
  alone: `unmeasured`) and while the live guard sees enough free memory (`low` is False).
- A package starts (it takes a worker), and a step of it starts (its make or Ninja runs its
  first job without a token), when the committed memory plus what it needs fits, or when
  nothing else runs: what cannot fit even alone runs alone (`Verdict.alone`). A package
  without a prediction needs the largest prediction known; while none is known, no other
  package without one starts beside it; and while a make or Ninja of one without a
  prediction runs its first, unmeasured job, no step of another such package starts.
"""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True, slots=True)
class Need:
    """What a package, or one step of it, is predicted to need, in bytes (None: unknown)."""

    #: the peak of one job under its make or Ninja (a compile, a link)
    job: int | None = None
    #: the peak of its processes when it runs no make or Ninja, or of its first job when it
    #: does: what it takes to start
    start: int | None = None
    #: anything is known of the package (recorded, or measured in this run)
    known: bool = False


@dataclass(frozen=True, slots=True)
class Running:
    """A package that holds a worker, as measured now, with what its step is predicted to
    need."""

    name: str
    #: its processes' resident memory now
    rss: int = 0
    #: each of its jobs' resident memory now
    jobs: tuple[int, ...] = ()
    #: a make or Ninja of its runs (its jobs may take tokens)
    driving: bool = False
    need: Need = Need()
    #: a step of it with no prediction started and none of its jobs was measured yet
    measuring: bool = False


@dataclass(frozen=True, slots=True)
class MemoryState:
    """What the governor knows at one moment."""

    budget: int
    #: the build's process tree now (wsbuild's own process included)
    total: int
    running: tuple[Running, ...]
    #: tokens in circulation (in the FIFO or held by a make or Ninja)
    tokens_out: int
    #: the largest need known (of any package), for a package or step without one
    fallback: int | None
    #: free memory is below the margin (the live guard)
    low: bool = False

    @property
    def outside(self) -> int:
        """What no package's processes hold: wsbuild itself, helpers."""
        return max(0, self.total - sum(p.rss for p in self.running))


def _job(package: Running, fallback: int | None) -> int:
    """The job peak a package's step is predicted to reach (else the fallback), never below
    what its running jobs hold now."""
    predicted = package.need.job
    if predicted is None:
        predicted = package.need.start if package.need.start is not None else fallback or 0
    return max([predicted, *package.jobs])


def _own(package: Running, fallback: int | None) -> tuple[int, int]:
    """What a running package commits (bytes), and how many tokens its jobs hold: a make or
    Ninja runs one job on its implicit slot, each further job holds a token."""
    job = _job(package, fallback)
    start = package.need.start
    floor = (fallback or 0) if start is None else start
    if package.driving and package.jobs:
        overhead = package.rss - sum(package.jobs)
        return max(floor, overhead + sum(max(rss, job) for rss in package.jobs)), \
            len(package.jobs) - 1
    if package.driving:  # between jobs: the implicit slot's next one
        return max(floor, package.rss + job), 0
    return max(package.rss, floor), 0


def _token_job(state: MemoryState) -> int:
    """What a free token may start: the largest job of a running package (one that runs no
    make or Ninja yet may start one that takes it)."""
    return max((_job(p, state.fallback) for p in state.running), default=0)


def committed(state: MemoryState) -> tuple[int, int]:
    """The memory committed now, and the tokens in circulation that no job holds."""
    total, held = state.outside, 0
    for package in state.running:
        own, tokens = _own(package, state.fallback)
        total += own
        held += tokens
    free = max(0, state.tokens_out - held)
    return total + free * _token_job(state), free


def unmeasured(state: MemoryState) -> list[str]:
    """Running packages whose make or Ninja runs a step of which no job was measured."""
    return [p.name for p in state.running if p.driving and p.need.job is None]


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
    """May it start now; when not, why; `alone`: it cannot fit even alone."""

    start: bool
    why: str = ""
    alone: bool = False


def may_start(state: MemoryState, name: str, need: Need) -> Verdict:
    """Whether the package (or the step of it) `name`, predicted to need `need`, may start
    now (see the module): a package's own entry in `state`, if any, is what it holds now,
    replaced by what the step needs."""
    others = tuple(p for p in state.running if p.name != name)
    own = next((p for p in state.running if p.name == name), None)
    start = need.start if need.known else None
    if start is None:
        start = state.fallback
    alone = start is not None and state.outside + start > state.budget
    if not others:
        return Verdict(True, alone=alone)
    if state.low:
        return Verdict(False, "free memory is below the margin")
    if alone:
        return Verdict(False, "it does not fit beside others", alone=True)
    if start is None:
        if any(not p.need.known for p in others) and own is None:
            first = next(p.name for p in others if not p.need.known)
            return Verdict(False, f"nothing is known yet: {first} is measured first")
        start = 0
    if not need.known and need.job is None:
        # a make or Ninja of a package never recorded runs one job until it is measured:
        # two such at once could each need the whole budget
        measuring = [p.name for p in others if p.measuring]
        if measuring:
            return Verdict(False, f"the first job of {measuring[0]} is measured first")
    waiting = Running(name, own.rss if own is not None else 0, need=replace(
        need, start=start, job=need.job if need.job is not None else start))
    memory, _ = committed(replace(state, running=(*others, waiting)))
    if memory > state.budget:
        return Verdict(False, "what runs leaves no room")
    return Verdict(True)
