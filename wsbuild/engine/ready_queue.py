"""Which job may start next: the one answer the scheduler (schedule.py) and a plan's start
order (builder/plan.py, shown by `build --dry-run`) share.

A job is *ready* when every dependency among the run's jobs is settled. Among ready jobs the
one with the most *remaining work* starts first: its own weight plus the heaviest chain of
jobs that (transitively) depend on it (critical path first); ties go to the earlier job in
the given order, which wsbuild's runs make topological with ties broken by name, so the order
is deterministic. `JobGraph` holds the jobs with their dependencies and the reverse map
(each job's dependents), built once per graph.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Collection, Iterable, Mapping
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class JobGraph:
    """A run's jobs in their given order, each one's dependencies among them, and the reverse
    map: each one's dependents, in the given order."""

    order: tuple[str, ...]
    dependencies: Mapping[str, frozenset[str]]
    dependents: Mapping[str, tuple[str, ...]]

    @classmethod
    def of(cls, order: Iterable[str], dependencies: Mapping[str, Iterable[str]]) -> JobGraph:
        """The graph of the jobs `order` names; dependencies outside them are left out (a job
        missing from `dependencies` has none)."""
        names = tuple(dict.fromkeys(order))
        members = set(names)
        needs = {n: frozenset(dependencies.get(n, ())) & members - {n} for n in names}
        users: dict[str, list[str]] = {n: [] for n in names}
        for name in names:
            for dep in needs[name]:
                users[dep].append(name)
        return cls(names, needs, {n: tuple(u) for n, u in users.items()})

    def subset(self, names: Collection[str]) -> JobGraph:
        """The jobs of `names` (in this graph's order) with the edges among them; the reverse
        map is this one's, filtered."""
        kept = set(names)
        return JobGraph(tuple(n for n in self.order if n in kept),
                        {n: deps & kept for n, deps in self.dependencies.items() if n in kept},
                        {n: tuple(u for u in users if u in kept)
                         for n, users in self.dependents.items() if n in kept})

    def remaining_work(self, weights: Mapping[str, float]) -> dict[str, float]:
        """For every job: its weight plus the heaviest chain of jobs that depend on it,
        directly or not (a missing weight is 0). Raises ValueError on a dependency cycle."""
        pending = {name: len(self.dependencies[name]) for name in self.order}
        # Kahn's order, then sum up from the last dependents backwards
        kahn = [name for name in self.order if not pending[name]]
        for name in kahn:
            for user in self.dependents[name]:
                pending[user] -= 1
                if not pending[user]:
                    kahn.append(user)
        if len(kahn) != len(self.order):
            raise ValueError("dependency cycle among "
                             + ", ".join(sorted(set(self.order) - set(kahn))))
        result: dict[str, float] = {}
        for name in reversed(kahn):
            result[name] = max(0.0, float(weights.get(name, 0.0))) + max(
                (result[user] for user in self.dependents[name]), default=0.0)
        return result

    def critical_path(self, weights: Mapping[str, float]) -> list[str]:
        """The heaviest chain of jobs, dependencies first: the lower bound of a run's wall
        time with unlimited workers. Ties go to the job first in the given order."""
        remaining = self.remaining_work(weights)
        position = {name: index for index, name in enumerate(self.order)}

        def best(candidates: Iterable[str]) -> str | None:
            return min(candidates, key=lambda n: (-remaining[n], position[n]), default=None)

        path: list[str] = []
        current = best(n for n in self.order if not self.dependencies[n])
        while current is not None:
            path.append(current)
            current = best(self.dependents[current])
        return path


class ReadyQueue:
    """The jobs of a graph that may start, most remaining work first, then in the given order.
    `pop()` hands out the next one; `settle()` tells that a job is done (or will never run),
    and whether its dependents may go on as if it succeeded (`release`)."""

    def __init__(self, jobs: JobGraph, weights: Mapping[str, float] | None = None) -> None:
        self.jobs = jobs
        remaining = jobs.remaining_work(weights or {})
        self._priority = {name: (-remaining[name], index)
                          for index, name in enumerate(jobs.order)}
        self._waiting = {name: set(jobs.dependencies[name]) for name in jobs.order}
        self._settled: set[str] = set()
        self._heap = [self._priority[name] for name in jobs.order if not self._waiting[name]]
        heapq.heapify(self._heap)

    def pop(self, accept: Callable[[str], bool] | None = None) -> str | None:
        """The next job to start (None: none is ready now); with `accept`, the first in the
        queue's order that it accepts (the others stay ready)."""
        passed = []
        found = None
        while self._heap:
            entry = heapq.heappop(self._heap)
            name = self.jobs.order[entry[1]]
            if name in self._settled:  # a job settled while ready (skipped) never starts
                continue
            if accept is None or accept(name):
                found = name
                break
            passed.append(entry)
        for entry in passed:
            heapq.heappush(self._heap, entry)
        return found

    def has_ready(self) -> bool:
        return any(self.jobs.order[entry[1]] not in self._settled for entry in self._heap)

    def settle(self, name: str, *, release: bool = True) -> None:
        """`name` is done: with `release`, a dependent whose dependencies are all released
        becomes ready."""
        self._settled.add(name)
        if not release:
            return
        for user in self.jobs.dependents[name]:
            waiting = self._waiting[user]
            waiting.discard(name)
            if not waiting and user not in self._settled:
                heapq.heappush(self._heap, self._priority[user])


def start_order(jobs: JobGraph, weights: Mapping[str, float] | None = None) -> list[str]:
    """The order the scheduler starts `jobs` in with one worker, each one succeeding."""
    queue = ReadyQueue(jobs, weights)
    order: list[str] = []
    while (name := queue.pop()) is not None:
        order.append(name)
        queue.settle(name)
    return order
