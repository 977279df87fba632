"""One shard of a build split across the jobs of a CI matrix (`build --shard K/N`), around the
split of builder/shards/split.py. The build cache's server is where the shards meet:

1. the times: each package's recorded build time, from the server's shared document (what
   earlier shards built), else this workspace's last run (build/.wsbuild/durations.json);
   an unknown package weighs its estimate, scaled to the recorded ones (split.py);
2. the split, on the times fixed for the run (builder/shards/cover.py: the run is
   `WSBUILD_SHARD_RUN`, GitHub's run id, GitLab's pipeline id, else the commit's workspace),
   and what each shard of the same run planned (its note). A note of the same workspace with
   another split (the workers differ) is taken over, so all shards build by one split; a
   note of another workspace is said in one line, and this shard waits for none of that
   shard's packages;
3. the plan of this shard's packages and those of other shards they need (builder/plan.py);
   the latter are restored when the plan finds them, else waited for (cache/waiting.py)
   for a bounded time (`Split.waits`), then restored, or built here;
4. afterwards the times of what this shard built go into the shared document.

Nothing here decides what an install holds: every entry is restored only when this machine
proves it (cache/run.py), so a shard that died, a lost entry or a peer with another workspace
costs time, never a wrong install.

Over 500 lines because a shard's run is one sequence, read top to bottom: its times, its
split, its peers' notes, its waits and the times it publishes (the split itself, pure logic,
is split.py).
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild import inputs
from wsbuild.builder.shards.cover import TIMES, run_of, run_times, shared_times
from wsbuild.builder.shards.split import (
    ShardSpec,
    Split,
    calibrated_weights,
    graph_digest,
    split_packages,
)
from wsbuild.cache.documents import SharedDocuments
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.engine.logs import append_command_log
from wsbuild.engine.ready_queue import JobGraph
from wsbuild.engine.timings import read_durations
from wsbuild.events import Emit, Notice
from wsbuild.files import atomic_write
from wsbuild.words import plural
from wsbuild.workspace.selection import Selection

if TYPE_CHECKING:
    from wsbuild.builder.plan import BuildPlan, PackagePlan
    from wsbuild.cache.settings import CacheSettings
    from wsbuild.engine.memory_records import PackageMemoryRecord
    from wsbuild.session import Session

#: under the build base: the split this workspace's last `build --shard` ran (`test --shard`
#: tests the same packages)
LOCAL_SPLIT = Path(".wsbuild") / "shard.json"
#: how often a waiting shard looks for the note of a peer that has not written one yet
NOTE_LOOK_EVERY = 5.0


def note_name(run: str, count: int, index: int) -> str:
    return f"shard note {run} {count} {index}"


@dataclass(slots=True)
class ShardLog:
    """What the shard's run did beyond its own packages (filled while it runs)."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    #: package of another shard → seconds waited, and whether it was then restored
    waited: dict[str, tuple[float, bool]] = field(default_factory=dict)
    #: packages built here after their wait ended, with why, and their build's seconds
    built_here: dict[str, tuple[str, float]] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class ShardPlan:
    """Shard K's part of the plan: the split, its own packages, the packages of other shards
    it needs with their waits (seconds from the start), what the peers' notes said."""

    spec: ShardSpec
    split: Split
    own: tuple[str, ...]
    #: packages of other shards this one needs → seconds from its start it waits for each
    waits: Mapping[str, float]
    #: the weights its scheduler ranks its packages by (`Split.priorities`): their work in
    #: the whole split
    priorities: Mapping[str, float]
    #: the graph digest of this shard's selection (notes compare it)
    workspace: str
    #: peers (shard numbers) whose note showed another workspace: nothing is waited for
    strangers: frozenset[int] = frozenset()
    #: lines said once the plan is made (taken split, another workspace)
    notices: tuple[tuple[str, bool], ...] = ()
    log: ShardLog = field(default_factory=ShardLog, compare=False)
    #: what each package needed in memory, as the matrix's jobs shared it (builder/resources/memory.py)
    memory: Mapping[str, PackageMemoryRecord] = field(default_factory=dict, compare=False)

    def owner(self, name: str) -> int:
        return self.split.assignment[name]


# ----------------------------------------------------------------------------- the times

def recorded_times(documents: SharedDocuments | None, build_base: Path, run: str = "",
                   *, fix: bool = False) -> dict[str, float]:
    """The packages' recorded build times: on the server, those fixed for `run`, else its
    shared document (copied for the run when `fix`: builder/shards/cover.py); without a
    server, this workspace's last run."""
    if documents is not None:
        times = run_times(documents, run, fix=fix, scratch=build_base / ".wsbuild") if run \
            else shared_times(documents)
        if times is not None:
            return times

    return read_durations(build_base)


def split_of(selection: Selection, count: int, workers: int,
             documents: SharedDocuments | None, run: str = "", *, fix: bool = False) -> Split:
    """The split of the selection into `count` shards of `workers` workers, balanced on the
    recorded times (`recorded_times`: those fixed for `run` when there is a server)."""
    from wsbuild.builder.weights import estimate_seconds  # lazy: off `test --shard`

    jobs = selection_jobs(selection)
    times = recorded_times(documents, selection.workspace.build_base, run, fix=fix)
    estimates = {n: estimate_seconds(selection.packages[n]) for n in jobs.order
                 if n not in times}
    weights, estimated = calibrated_weights(jobs.order, times, estimates)
    return split_packages(jobs, weights, count, workers, estimated=estimated)


def selection_jobs(selection: Selection) -> JobGraph:
    """The selected packages with their dependencies among them: the graph a one-machine
    build schedules (builder/plan.py)."""
    selected = set(selection.selected)
    return JobGraph.of(selection.selected,
                       {n: selection.graph.direct(n) & selected for n in selection.selected})


# ----------------------------------------------------------------------------- the plan

def shard_selection(selection: Selection, spec: ShardSpec, workers: int,
                    session: Session) -> tuple[Selection, ShardPlan]:
    """This shard's selection (its packages and those of other shards they need) and its
    part of the plan."""
    from wsbuild.builder.resources.memory import shared_memory  # lazy: off `test --shard`

    spec = replace(spec, run=run_of(selection, spec.run))
    documents = SharedDocuments.open(session.cache.settings)
    try:
        memory = shared_memory(documents)
        split = split_of(selection, spec.count, workers, documents, spec.run, fix=True)
        workspace = graph_digest(split.jobs)
        notices: list[tuple[str, bool]] = []
        strangers: set[int] = set()
        if documents is not None and spec.run:
            split, strangers = _meet_peers(documents, spec, split, workspace, notices)
        notices += [(f"cache: {problem}", True) for problem in documents.problems] \
            if documents is not None else []
    finally:
        if documents is not None:
            documents.close()
    closure = {name: selection.graph.build_closure(name) for name in split.jobs.order}
    needed = split.needed(spec.index, closure)
    own = split.packages(spec.index)
    waits = {name: (0.0 if split.assignment[name] in strangers else seconds)
             for name, seconds in split.waits(spec.index, needed).items()}
    notices.insert(0, (_plan_line(spec, split, own, waits), False))
    shard = ShardPlan(spec, split, own, waits, split.priorities(needed), workspace,
                      frozenset(strangers), tuple(notices), memory=memory)
    return Selection(selection.workspace, selection.packages, selection.graph,
                    list(needed)), shard


def _plan_line(spec: ShardSpec, split: Split, own: Sequence[str],
               waits: Mapping[str, float]) -> str:
    known = len(split.assignment) - len(split.estimated)
    times = f"recorded times of {known}" if known else "no recorded times yet"
    if split.estimated:
        times += f", {len(split.estimated)} estimated from their files"
    others = f"; it needs {plural(len(waits), 'package')} of other shards" if waits else ""
    return (f"shard {spec.label}: {len(own)} of {plural(len(split.assignment), 'package')}, "
            f"predicted {split.shard_seconds(spec.index):.0f} s, the slowest shard "
            f"{split.predicted:.0f} s ({times}){others}")


def _meet_peers(documents: SharedDocuments, spec: ShardSpec, split: Split, workspace: str,
                notices: list[tuple[str, bool]]) -> tuple[Split, set[int]]:
    """The split after reading the notes the run's other shards wrote so far: one of the same
    workspace but another split is taken (the lowest shard's), one of another workspace is
    said and its shard marked a stranger."""
    strangers: set[int] = set()
    taken: tuple[int, Mapping[str, int]] | None = None
    for peer in range(1, spec.count + 1):
        if peer == spec.index:
            continue
        note = documents.get(note_name(spec.run, spec.count, peer))
        if note is None:
            continue
        if note.get("workspace") != workspace:
            strangers.add(peer)
            notices.append((stranger_line(spec, peer, note, split), True))
        elif note.get("split") != split.digest and taken is None:
            assignment = note.get("assignment")
            if isinstance(assignment, dict) and set(assignment) == set(split.assignment) \
                    and all(isinstance(v, int) and 1 <= v <= spec.count
                            for v in assignment.values()):
                taken = (peer, assignment)
    if taken is None:
        return split, strangers
    peer, assignment = taken
    notices.append((f"shard {spec.label} builds by the split shard {peer}/{spec.count} "
                    "planned for this run (the recorded times or the workers it split by "
                    "differ from this job's)", False))
    adopted = split_packages(split.jobs, split.weights, split.count, split.workers,
                             estimated=split.estimated, transfer=split.transfer,
                             assignment=assignment)
    return adopted, strangers


def stranger_line(spec: ShardSpec, peer: int, note: Mapping[str, object], split: Split) -> str:
    """The one line saying that shard `peer` planned another workspace, and what differs."""
    theirs = note.get("assignment")
    there = set(theirs) if isinstance(theirs, dict) else set()
    here = set(split.assignment)
    if there != here:
        only_there, only_here = sorted(there - here), sorted(here - there)
        what = "; ".join(part for part in (
            f"only there: {', '.join(only_there[:3])}{' …' if len(only_there) > 3 else ''}"
            if only_there else "",
            f"only here: {', '.join(only_here[:3])}{' …' if len(only_here) > 3 else ''}"
            if only_here else "") if part)
    else:
        what = "the same packages with other dependencies"
    return (f"shard {peer}/{spec.count} of this run planned another workspace ({what}), so "
            f"its split differs from this one's: shard {spec.label} waits for none of its "
            "packages and builds those it needs itself; check that every job of the matrix "
            "checks out the same commit")


def announce(shard: ShardPlan, packages: Sequence[PackagePlan], session: Session) -> list[str]:
    """Write what this shard planned: its note for the run's other shards (when the run is
    known) and the split for `test --shard` (build/.wsbuild/shard.json). Returns what could
    not be written."""
    spec, split = shard.spec, shard.split
    body = {"run": spec.run, "shard": spec.index, "shards": spec.count,
            "workers": split.workers, "workspace": shard.workspace, "split": split.digest,
            "assignment": dict(split.assignment)}
    local = session.workspace.build_base / LOCAL_SPLIT
    local.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(local, json.dumps(body, indent=1, sort_keys=True) + "\n")
    documents = SharedDocuments.open(session.cache.settings) if spec.run else None
    if documents is None:
        return []
    own = set(shard.own)
    body["addresses"] = {p.name: p.cache_key.address for p in packages
                         if p.name in own and p.cache_key is not None}
    try:
        documents.put(note_name(spec.run, spec.count, spec.index), body, "note",
                      session.workspace.build_base / ".wsbuild")
        return list(documents.problems)
    finally:
        documents.close()


# ----------------------------------------------------------------------------- the run

def start(plan: BuildPlan, shard: ShardPlan, session: Session, emit: Emit) -> None:
    """Before the packages: what the plan said of the shard, and its note."""
    for text, warning in shard.notices:
        emit(Notice(text, warning=warning))
    for problem in announce(shard, plan.packages, session):
        emit(Notice(f"cache: {problem}", warning=True))


def finish(plan: BuildPlan, shard: ShardPlan, results: Sequence[JobResult], session: Session,
           emit: Emit) -> tuple[str, ...]:
    """After the packages: the times of what the shard built into the shared document, and
    the summary's line on what it waited for."""
    from wsbuild.builder.resources.memory import publish_memory  # lazy: off `test --shard`

    times = built_times(shard, {p.name: p for p in plan.packages}, results)
    for problem in publish_times(session.cache.settings, times,
                                 session.workspace.build_base / ".wsbuild") + publish_memory(
            session.cache.settings, times, session.workspace.build_base):
        emit(Notice(f"cache: {problem}", warning=True))
    return tuple(summary_lines(shard, results))


@dataclass(slots=True)
class _Peers:
    """The notes of the shards this one waits for, fetched while it waits (at most every
    `NOTE_LOOK_EVERY` seconds per peer, until found)."""

    shard: ShardPlan
    settings: CacheSettings | None
    notes: dict[int, Mapping[str, object]] = field(default_factory=dict)
    looked: dict[int, float] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def verdict(self, name: str, address: str) -> str:
        """Why waiting for `name` is pointless ("" while it is not): its shard's note shows
        another workspace, or another build of it."""
        spec, peer = self.shard.spec, self.shard.owner(name)
        if not spec.run:
            return ""
        note = self._note(peer)
        if note is None:
            return ""
        if note.get("workspace") != self.shard.workspace:
            return f"shard {peer}/{spec.count} planned another workspace"
        addresses = note.get("addresses")
        if isinstance(addresses, dict) and name in addresses and addresses[name] != address:
            return f"shard {peer}/{spec.count} builds it from other inputs"
        return ""

    def _note(self, peer: int) -> Mapping[str, object] | None:
        with self.lock:
            if peer in self.notes:
                return self.notes[peer]
            now = time.monotonic()
            if now - self.looked.get(peer, -NOTE_LOOK_EVERY) < NOTE_LOOK_EVERY:
                return None
            self.looked[peer] = now
        documents = SharedDocuments.open(self.settings)
        if documents is None:
            return None
        try:
            note = documents.get(note_name(self.shard.spec.run, self.shard.spec.count, peer))
        finally:
            documents.close()
        if note is not None:
            with self.lock:
                self.notes[peer] = note
        return note


def with_waits(plan: BuildPlan, shard: ShardPlan) -> BuildPlan:
    """The plan of a shard: each package it would build that another shard builds (and whose
    entry the plan did not find) is waited for first (`PackagePlan.wait`), as `--dry-run`
    says."""
    from wsbuild.builder.plan import Decision, ShardWait  # lazy: off `plan`

    count = shard.spec.count
    return replace(plan, packages=tuple(
        replace(p, wait=ShardWait(f"{shard.owner(p.name)}/{count}", shard.waits[p.name]))
        if p.name in shard.waits and p.decision is Decision.BUILD and p.cache_key is not None
        else p for p in plan.packages))


def shard_jobs(shard: ShardPlan, planned: Mapping[str, PackagePlan],
               build: Callable[[PackagePlan], JobResult], session: Session, emit: Emit,
               started: float) -> tuple[Callable[[str], JobResult], frozenset[str]]:
    """The scheduler's job for each package of the run, and the jobs that take no worker
    (those waiting for other shards): a package of another shard that the plan did not find
    in the cache is waited for until its deadline, then restored if it came, else built here
    (`build`: one package's build as the plan says, builder/package.py)."""

    peers = _Peers(shard, session.cache.settings)
    waiting = frozenset(name for name, p in planned.items() if p.wait is not None)

    def job(name: str) -> JobResult:
        wait = planned[name].wait
        if wait is None:
            return build(planned[name])
        return _wait_then_build(shard, planned[name], build, session, emit,
                                started + wait.seconds, peers)

    return job, waiting


def _wait_then_build(shard: ShardPlan, planned: PackagePlan,
                     build: Callable[[PackagePlan], JobResult], session: Session, emit: Emit,
                     until: float, peers: _Peers) -> JobResult:
    from wsbuild.builder.plan import Decision  # lazy: off `plan`
    from wsbuild.builder.records import dependency_keys  # lazy: off `test --shard` and `plan`
    from wsbuild.cache.waiting import wait_for_entry  # lazy: off `build --shard` and `test --shard`

    name = planned.name
    assert planned.cache_key is not None
    owner = f"shard {shard.owner(name)}/{shard.spec.count}"
    address = planned.cache_key.address
    waited = wait_for_entry(
        session.cache, planned.cache_key, planned.inputs_key,
        dependency_keys(planned, session.workspace.build_base), session.digests, until=until,
        give_up=lambda: peers.verdict(name, address))
    log_dir = session.run_log / name if session.run_log is not None else None
    if waited.proven is not None:
        _log(log_dir, f"Waited {waited.seconds:.1f} s for {owner}'s build ({waited.looks} "
             "looks at the cache)")
        with shard.log.lock:
            shard.log.waited[name] = (waited.seconds, True)
        result = build(replace(planned, decision=Decision.RESTORE, cache_entry=waited.proven))
        if result.outcome is Outcome.FINISHED and not result.restored:
            with shard.log.lock:  # the restore was refused: it was built here
                shard.log.built_here[name] = ("its entry could not be restored",
                                              result.seconds)
        return result
    why = f"{owner} builds it; {waited.why_not}"
    _log(log_dir, f"Building it here after waiting {waited.seconds:.1f} s: {why}")
    emit(Notice(f"{name}: building it here ({why})", package=name))
    before = time.monotonic()
    result = build(planned)
    with shard.log.lock:
        shard.log.waited[name] = (waited.seconds, False)
        if result.outcome is Outcome.FINISHED:
            shard.log.built_here[name] = (waited.why_not, time.monotonic() - before)
    return result


def _log(log_dir: Path | None, line: str) -> None:
    if log_dir is not None:
        append_command_log(log_dir, line)


def summary_lines(shard: ShardPlan, results: Sequence[JobResult]) -> list[str]:
    """The summary's line on what the shard did beyond its own packages."""
    log = shard.log
    restored = sorted(n for n, (_, came) in log.waited.items() if came)
    waited = sum(seconds for seconds, _ in log.waited.values())
    parts = [f"shard {shard.spec.label}: {plural(len(shard.own), 'package')} of its own"]
    if shard.waits:
        parts.append(f"{plural(len(shard.waits), 'package')} of other shards needed, "
                     f"{len(restored)} of them restored after waiting ({waited:.1f} s in all)")
    if log.built_here:
        parts.append(f"built here after the wait: {' '.join(sorted(log.built_here))}")
    return ["; ".join(parts)]


def built_times(shard: ShardPlan, planned: Mapping[str, PackagePlan],
                results: Sequence[JobResult]) -> dict[str, float]:
    """The build times of the packages this shard built (not restored): its own packages
    the plan built, and those of other shards it built after their wait."""
    from wsbuild.builder.plan import Decision  # lazy: off `plan`

    times = {}
    own = set(shard.own)
    for result in results:
        if result.outcome is not Outcome.FINISHED:
            continue
        name = result.package
        if name in shard.log.built_here:
            times[name] = shard.log.built_here[name][1]
        elif name in own and name in planned and planned[name].decision is Decision.BUILD:
            times[name] = result.seconds
    return {name: round(seconds, 3) for name, seconds in sorted(times.items())}


def publish_times(settings: CacheSettings | None, times: Mapping[str, float],
                  scratch: Path) -> list[str]:
    """Merge `times` into the server's shared document; once more when another shard wrote
    it meanwhile and ours are not in it. Returns what could not be done."""
    documents = SharedDocuments.open(settings)
    if documents is None or not times:
        return []
    try:
        for _attempt in (1, 2):
            current = documents.get(TIMES)
            known = current.get("times") if current is not None else None
            merged = dict(known) if isinstance(known, dict) else {}
            merged.update(times)
            if not documents.put(TIMES, {"times": dict(sorted(merged.items()))}, "times",
                                 scratch):
                break
            again = documents.get(TIMES)
            now = again.get("times") if again is not None else None
            if isinstance(now, dict) and all(now.get(k) == v for k, v in times.items()):
                break
        return list(documents.problems)
    finally:
        documents.close()


# ----------------------------------------------------------------------------- test --shard

def test_selection(selection: Selection, spec: ShardSpec, workers: int,
                   settings: CacheSettings | None) -> tuple[Selection, str]:
    """`test --shard K/N`: shard K's packages of the split the last `build --shard` here ran
    (build/.wsbuild/shard.json), when it is of this selection and N; else of the split that
    build would make. Returns the selection and a line saying which."""
    jobs = selection_jobs(selection)
    assignment: Mapping[str, int] | None = None
    try:
        local = json.loads(inputs.read_text(selection.workspace.build_base / LOCAL_SPLIT))
    except (OSError, ValueError):
        local = None
    if isinstance(local, dict) and local.get("shards") == spec.count \
            and local.get("workspace") == graph_digest(jobs) \
            and isinstance(local.get("assignment"), dict):
        assignment = local["assignment"]
        source = "the split `build --shard` ran here"
    else:
        documents = SharedDocuments.open(settings)
        try:
            assignment = split_of(selection, spec.count, workers, documents,
                                  run_of(selection, spec.run)).assignment
        finally:
            if documents is not None:
                documents.close()
        source = "the split `build --shard` would make (none ran here)"
    own = [name for name in selection.selected if assignment.get(name) == spec.index]
    line = (f"shard {spec.label}: testing {plural(len(own), 'package')} of "
            f"{len(selection.selected)}, by {source}")
    return Selection(selection.workspace, selection.packages, selection.graph, own), line
