"""The split of a build across the N jobs of a CI matrix (`build --shard K/N`, `test --shard
K/N`, `plan --shards N`): which shard builds which package, when each package is predicted to
be done, and for shard K how long it waits for each package of another shard that it needs.

Pure logic: the weights (recorded times) come in, the split comes out; builder/shards/run.py
reads the times, meets the other shards in the build cache and runs the waits.

How the split is chosen: a list schedule of the selected packages on N machines of W workers
each (W: `--parallel-workers`, the CPUs by default). The packages are taken in the order of
the scheduler's ready queue (the most remaining work first, engine/ready_queue.py), and each
goes to the machine where it can start first: a worker free there, and its dependencies done
(on the same machine at once, on another `TRANSFER_SECONDS` later, the time to upload, notice
and restore it). A dependency chain so stays on one machine unless another can start its next
package earlier by more than that; between machines where it starts at the same time, the one
holding more of its dependencies' work takes it, then the one with less work so far, then the
first. Each machine's packages are fitted into the earliest gap of a worker's timeline that
holds them (insertion), so a package waiting for another machine leaves its worker to others.
The result is deterministic: the same packages, dependencies, weights, N and W give the same
split on every machine, so the jobs of a matrix need no coordinator.
"""

from __future__ import annotations

import bisect
import hashlib
import json
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from wsbuild.engine.ready_queue import JobGraph
from wsbuild.errors import WsbuildError

#: seconds from a package finished on one machine to its install restored on another: the
#: owner's upload, the waiter's next look at the cache, the download and unpacking
TRANSFER_SECONDS = 3.0
#: a wait lasts the predicted arrival plus this share of it (machines and loads differ) ...
WAIT_SHARE = 0.25
#: ... plus the longer of this and half the package's own time
WAIT_GRACE_SECONDS = 10.0


@dataclass(frozen=True, slots=True)
class Assembly:
    """What `--assemble N` asks: the job after a matrix of `count` shards of the CI run
    `run` ("": none known, the commit's workspace is the run)."""

    count: int
    run: str = ""


@dataclass(frozen=True, slots=True)
class ShardSpec:
    """What `--shard K/N` asks: the K-th of N shards (1-based), and the CI run the shards
    belong to ("": none known, the shards cannot check each other's splits)."""

    index: int
    count: int
    run: str = ""

    @property
    def label(self) -> str:
        return f"{self.index}/{self.count}"


def parse_shard(text: str, *, run: str = "") -> ShardSpec:
    """`--shard K/N` → ShardSpec; a usage error naming the value otherwise."""
    index_text, slash, count_text = text.strip().partition("/")
    if slash and index_text.isdigit() and count_text.isdigit():
        index, count = int(index_text), int(count_text)
        if 1 <= index <= count:
            return ShardSpec(index, count, run)
    raise WsbuildError(f"--shard takes K/N with 1 <= K <= N, got {text!r}",
                       hint="e.g. --shard 2/3 for the second of three jobs")


def shard_run_id(environ: Mapping[str, str]) -> str:
    """The CI run the jobs of a matrix share, from the environment: `WSBUILD_SHARD_RUN`,
    GitHub Actions' run id (a job run again keeps it), GitLab's pipeline id ("": none
    known)."""
    if environ.get("WSBUILD_SHARD_RUN"):
        return environ["WSBUILD_SHARD_RUN"]
    if environ.get("GITHUB_RUN_ID"):
        return f"github-{environ['GITHUB_RUN_ID']}"
    if environ.get("CI_PIPELINE_ID"):
        return f"gitlab-{environ['CI_PIPELINE_ID']}"
    return ""


def parse_shard_count(text: str, *, option: str = "--shards") -> int:
    """`--shards N` (or `--assemble N`) → N (at least 1); a usage error naming the value
    otherwise."""
    if text.strip().isdigit() and int(text) >= 1:
        return int(text)
    example = "wsbuild plan --shards 3 --json" if option == "--shards" \
        else f"wsbuild build {option} 3"
    raise WsbuildError(f"{option} takes a number of CI jobs (1 or more), got {text!r}",
                       hint=f"e.g. {example}")


def digest(value: object) -> str:
    """A short digest of a JSON value (keys sorted): how shards compare what they planned."""
    return hashlib.sha256(json.dumps(value, sort_keys=True).encode()).hexdigest()[:16]


def graph_digest(jobs: JobGraph) -> str:
    """The packages and their dependencies among them: two jobs whose workspaces give another
    digest cannot split alike."""
    return digest([[name, sorted(jobs.dependencies[name])] for name in sorted(jobs.order)])


def calibrated_weights(names: Iterable[str], recorded: Mapping[str, float],
                       estimates: Mapping[str, float]) -> tuple[dict[str, float], frozenset[str]]:
    """Each package's weight: its recorded time, else its estimate scaled by how recorded
    times compare with the estimates of the packages that have both (the median ratio; 1
    when none has both), so an unknown package weighs what its kind took here. Returns the
    weights and the names that were estimated."""
    names = list(names)
    ratios = sorted(recorded[n] / estimates[n] for n in names
                    if n in recorded and estimates.get(n, 0.0) > 0)
    scale = ratios[len(ratios) // 2] if ratios else 1.0
    weights: dict[str, float] = {}
    estimated = set()
    for name in names:
        if name in recorded:
            weights[name] = max(0.0, float(recorded[name]))
        else:
            weights[name] = max(0.0, estimates.get(name, 0.0) * scale)
            estimated.add(name)
    return weights, frozenset(estimated)


@dataclass(frozen=True, slots=True)
class Split:
    """Which shard builds each package and the predicted schedule."""

    count: int
    workers: int
    #: package → its shard (1-based), in the jobs' (topological) order
    assignment: Mapping[str, int]
    #: predicted start and finish of each package on its shard (seconds from the start)
    start: Mapping[str, float]
    finish: Mapping[str, float]
    weights: Mapping[str, float]
    #: the packages whose weight is an estimate (no recorded time)
    estimated: frozenset[str]
    jobs: JobGraph
    #: the same packages on one machine of `workers` workers: what one job takes
    one_machine: float
    critical_path: tuple[str, ...]
    critical_seconds: float
    transfer: float = TRANSFER_SECONDS

    def packages(self, index: int) -> tuple[str, ...]:
        """Shard `index`'s packages, in the jobs' order."""
        return tuple(name for name in self.jobs.order if self.assignment[name] == index)

    def shard_seconds(self, index: int) -> float:
        """When shard `index` is predicted to be done (0: it has no package)."""
        return max((self.finish[n] for n in self.packages(index)), default=0.0)

    @property
    def predicted(self) -> float:
        """The slowest shard's predicted time."""
        return max((self.shard_seconds(k) for k in range(1, self.count + 1)), default=0.0)

    @property
    def total(self) -> float:
        return sum(self.weights.values())

    @property
    def bound(self) -> float:
        """No split can be faster: max(critical path, all the work ÷ every worker)."""
        return max(self.critical_seconds, self.total / (self.count * self.workers))

    @property
    def digest(self) -> str:
        return digest([self.count, self.workers, sorted(self.assignment.items())])

    def needed(self, index: int, closure: Mapping[str, Iterable[str]]) -> tuple[str, ...]:
        """Shard `index`'s packages and what their builds need of the others' (`closure`:
        each package's build closure), in the jobs' order."""
        own = set(self.packages(index))
        wanted = set(own)
        for name in own:
            wanted.update(closure[name])
        return tuple(name for name in self.jobs.order if name in wanted)

    def waits(self, index: int, needed: Sequence[str]) -> dict[str, float]:
        """For each package of another shard that shard `index` needs (`needed`): the seconds
        from the start after which it stops waiting for it and builds it itself. The wait is
        the predicted arrival (its shard's predicted finish, then the transfer) with a margin
        of `WAIT_SHARE` of it and the longer of `WAIT_GRACE_SECONDS` and half the package's
        time; but never past the moment from which building it and what needs it here would
        end after one job building everything (`one_machine`), give or take a transfer: a
        shard whose peers never deliver is no slower than one job."""
        subset = self.jobs.subset(needed)
        remaining = subset.remaining_work(self.weights)
        waits: dict[str, float] = {}
        for name in needed:
            if self.assignment[name] == index:
                continue
            arrival = self.finish[name] + self.transfer
            margin = WAIT_SHARE * arrival + max(WAIT_GRACE_SECONDS, 0.5 * self.weights[name])
            latest = self.one_machine - remaining[name] + self.transfer
            waits[name] = round(max(0.0, min(arrival + margin, latest)), 3)
        return waits

    def priorities(self, needed: Sequence[str]) -> dict[str, float]:
        """Weights under which a shard's scheduler, over its `needed` packages only, ranks each
        by its remaining work in the whole split (engine/ready_queue.py ranks by the work left
        behind a package among the jobs it is given): a package whose dependents are built by
        other shards still comes first when they wait for it."""
        remaining = self.jobs.remaining_work(self.weights)
        subset = self.jobs.subset(needed)
        return {name: remaining[name] - max((remaining[user] for user in subset.dependents[name]),
                                            default=0.0)
                for name in subset.order}

    def matrix(self) -> dict[str, object]:
        """The split as JSON for a CI system (`wsbuild plan --shards N --json`): each shard's
        packages and predicted time, under `matrix.include` as GitHub Actions' matrix takes it."""
        include = [{"shard": f"{k}/{self.count}", "index": k,
                    "packages": list(self.packages(k)),
                    "predicted_seconds": round(self.shard_seconds(k), 1)}
                   for k in range(1, self.count + 1)]
        return {
            "shards": self.count, "workers": self.workers, "split": self.digest,
            "packages": len(self.assignment),
            "estimated": sorted(self.estimated),
            "predicted_seconds": round(self.predicted, 1),
            "one_machine_seconds": round(self.one_machine, 1),
            "critical_path_seconds": round(self.critical_seconds, 1),
            "bound_seconds": round(self.bound, 1),
            "matrix": {"include": include},
        }


def split_packages(jobs: JobGraph, weights: Mapping[str, float], count: int, workers: int, *,
                   estimated: frozenset[str] = frozenset(), transfer: float = TRANSFER_SECONDS,
                   assignment: Mapping[str, int] | None = None) -> Split:
    """The split of `jobs` into `count` shards of `workers` workers (see the module's
    docstring); with `assignment`, that split's schedule instead (a split taken from another
    shard: builder/shards/run.py)."""
    workers = max(1, workers)
    path = jobs.critical_path(weights)
    if assignment is not None or count == 1:
        placed, start, finish = _schedule(jobs, weights, count, workers, transfer, assignment)
    else:  # the better of two: each package where it starts first, or so with the critical
        # path kept on the first shard (ties: the first)
        tries = [_schedule(jobs, weights, count, workers, transfer, None),
                 _schedule(jobs, weights, count, workers, transfer, None, pinned=set(path))]
        placed, start, finish = min(tries, key=lambda t: max(t[2].values(), default=0.0))
    one = finish if count == 1 else _schedule(jobs, weights, 1, workers, transfer, None)[2]
    return Split(count=count, workers=workers, assignment=placed, start=start, finish=finish,
                 weights=dict(weights), estimated=estimated, jobs=jobs,
                 one_machine=max(one.values(), default=0.0), critical_path=tuple(path),
                 critical_seconds=sum(weights.get(n, 0.0) for n in path), transfer=transfer)


@dataclass(slots=True)
class _Machine:
    """One simulated machine of a split: its workers' busy intervals."""

    #: each worker's busy intervals, sorted
    timelines: list[list[tuple[float, float]]]
    work: float = 0.0

    def earliest(self, ready: float, length: float,
                 workers: Collection[int] | None = None) -> tuple[float, int]:
        """The earliest start at or after `ready` of a gap of `length` on some worker (of
        `workers`, when given), and that worker."""
        best = (float("inf"), 0)
        for number, timeline in enumerate(self.timelines):
            if workers is not None and number not in workers:
                continue
            begin = ready
            for busy_from, busy_to in timeline:
                if begin + length <= busy_from:
                    break
                begin = max(begin, busy_to)
            best = min(best, (begin, number))
        return best

    def take(self, worker: int, begin: float, length: float) -> None:
        bisect.insort(self.timelines[worker], (begin, begin + length))
        self.work += length


@dataclass(slots=True)
class _Placement:
    """Where a split placed each package, and when each finishes."""

    machines: list[_Machine]
    placed: dict[str, int] = field(default_factory=dict)
    finish: dict[str, float] = field(default_factory=dict)


def _schedule(jobs: JobGraph, weights: Mapping[str, float], count: int, workers: int,
              transfer: float, fixed: Mapping[str, int] | None,
              pinned: Collection[str] = ()
              ) -> tuple[dict[str, int], dict[str, float], dict[str, float]]:
    """(shard of each package, its start, its finish): the list schedule of the module's
    docstring, or with `fixed` the schedule of that assignment; `pinned` packages all go to
    the first machine."""
    remaining = jobs.remaining_work(weights)
    position = {name: index for index, name in enumerate(jobs.order)}
    # the ready queue's order; a dependency always comes before its dependents in it (its
    # remaining work is at least theirs, and ties go to the earlier in topological order)
    order = sorted(jobs.order, key=lambda n: (-remaining[n], position[n]))
    state = _Placement([_Machine([[] for _ in range(workers)]) for _ in range(count)])
    start: dict[str, float] = {}
    for name in order:
        length = max(0.0, float(weights.get(name, 0.0)))
        choices = [fixed[name] - 1] if fixed is not None else [0] if name in pinned \
            else range(count)
        best: tuple[float, float, float, int, int] | None = None
        for machine in choices:
            ready = max((state.finish[dep] + (0.0 if state.placed[dep] == machine else transfer)
                         for dep in jobs.dependencies[name]), default=0.0)
            begin, worker = state.machines[machine].earliest(ready, length, (
                None if not pinned or machine else {0} if name in pinned
                else set(range(1, workers)) or None))
            together = sum(weights.get(dep, 0.0) for dep in jobs.dependencies[name]
                           if state.placed[dep] == machine)
            candidate = (begin, -together, state.machines[machine].work, machine, worker)
            if best is None or candidate < best:
                best = candidate
        assert best is not None
        begin, _, _, machine, worker = best
        state.machines[machine].take(worker, begin, length)
        state.placed[name] = machine
        start[name] = begin
        state.finish[name] = begin + length
    placed = {name: state.placed[name] + 1 for name in jobs.order}
    return (placed, {n: round(start[n], 6) for n in jobs.order},
            {n: round(state.finish[n], 6) for n in jobs.order})
