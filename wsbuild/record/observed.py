"""What a package's steps were observed to do (observe/), as its record holds it: what lies
outside what the package itself makes and owns.

- left out: what the steps wrote, the package's outputs (its build directory, its stage and
  install prefix; a test run's results and logs), the machine's running state (`/proc`,
  `/sys`, `/dev`), a tool's own state (a compiler cache's storage), and the paths inside the
  package its own files already hold (record/own_files.py: a read below a name the own files
  leave out, `.git` or `__pycache__`, is kept);
- a compiled Python module read is held by its source (observe/log.py);
- a tree a step walked (fts, nftw) counts as every directory below it listed, a glob(3) as
  the directories its pattern lists;
- a path looked at or looked for is held in its directory's probes (what is there now), but
  one whose content or listing is held anyway;
- each variable a step read, by the value it saw (its first reader's), with the labels of the
  steps that read it; each path no build system watches (not in `tracked`), with the labels
  of the steps that read it, an own file by its name (`read_by`: a build type redoes them
  when it changes)."""

from __future__ import annotations

import glob as globbing
import os
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass

from wsbuild.observe.log import Observation, merged
from wsbuild.observe.steps import StepObservations
from wsbuild.record.environment import held
from wsbuild.record.outside import Digests, OutsideReads, OwnEntries, no_own_entries, take
from wsbuild.record.own_files import LEFT_OUT

#: the machine's running state, never a file's content
PSEUDO = ("/proc/", "/sys/", "/dev/")


@dataclass(frozen=True, slots=True)
class Where:
    """Where a package's steps ran: what is its own and what they make."""

    source_dir: str
    #: its build directory, stage and (isolated) install prefix; a test run's results
    outputs: tuple[str, ...]
    #: directories whose reads are a tool's own state (a compiler cache's storage)
    tool_state: tuple[str, ...] = ()

    def keeper(self) -> Callable[[str], bool]:
        """Whether a path read outside what the package owns and makes counts."""
        made = tuple(str(o).rstrip("/") + "/" for o in (*self.outputs, *self.tool_state))
        source = str(self.source_dir).rstrip("/") + "/"

        def keeps(path: str) -> bool:
            if path.startswith(PSEUDO) or not path.startswith("/"):
                return False
            probe = path + "/"
            if probe.startswith(made):
                return False
            if probe.startswith(source):
                rel = path[len(source):]
                return bool(rel) and any(part in LEFT_OUT for part in rel.split("/"))
            return True

        return keeps

    def own_name(self, path: str) -> str | None:
        """The name a path inside the package has among its own files (None: not one)."""
        source = str(self.source_dir).rstrip("/") + "/"
        if not path.startswith(source):
            return None
        rel = path[len(source):]
        return rel if rel and not any(part in LEFT_OUT for part in rel.split("/")) else None


@dataclass(frozen=True, slots=True)
class ObservedReads:
    """What the record holds of the steps' observations."""

    outside: OutsideReads
    #: variable -> the value its first reader saw (None: unset)
    seen: dict[str, str | None]
    #: outside path or `$NAME` -> the labels of the steps that read it, comma-separated
    read_by: dict[str, str]
    observation: Observation


def observed_reads(observations: StepObservations, where: Where, digests: Digests, *,
                   files: Iterable[str] = (), listings: Iterable[str] = (),
                   tracked: Collection[str] = (), started_ns: int = 0,
                   own: OwnEntries = no_own_entries,
                   extra_variables: Mapping[str, Sequence[str]] | None = None,
                   settled: Mapping[str, str] | None = None) -> ObservedReads:
    """What the record holds of `observations`: the outside reads (with `files` and
    `listings` a build type declares besides: what its in-process steps read, what its build
    system watches), digested (a path changed since `started_ns` held as racy); the values
    the steps saw of the variables they read (`extra_variables`: step label -> variables its
    steps read where nothing was observed, sccache's server's compiles)."""
    observation = merged(step.observation for step in observations.steps)
    keep = where.keeper()
    read = {p for p in observation.reads if keep(p)}
    listed = {p for p in observation.listings if keep(p)}
    listed.update(d for root in observation.trees if keep(root) for d in _tree(root))
    listed.update(d for pattern in observation.globs for d in _globbed(pattern) if keep(d))
    read.update(p for p in map(os.path.normpath, files) if keep(p))
    listed.update(p for p in map(os.path.normpath, listings) if keep(p))
    searches = {d: p for d, p in observation.searches.items() if keep(d) and d not in listed}
    probes = _probes((p for p in observation.present | observation.absent if keep(p)),
                     held=read | listed | set(searches))
    outside = take(read, listed, digests, searches=searches, probes=probes,
                   started_ns=started_ns, own=own, settled=settled)
    seen, variable_readers = _variables(observations, extra_variables or {})
    read_by = {**_readers(observations, keep, tracked, where), **variable_readers}
    return ObservedReads(outside, seen, read_by, observation)


def _variables(observations: StepObservations, extra: Mapping[str, Sequence[str]]
               ) -> tuple[dict[str, str | None], dict[str, str]]:
    """The variables the steps read with the value each had for the first step that read
    it, and `$NAME` -> the labels of the steps that read it (no build system watches a
    variable)."""
    seen: dict[str, str | None] = {}
    readers: dict[str, list[str]] = {}
    for step in observations.steps:
        read = set(step.observation.variables) | set(extra.get(step.label, ()))
        if step.observation.every_variable:
            read.update(n for n, v in step.environ.items() if v is not None)
        for name in sorted(read):
            if not held(name) or name in observations.run_only:
                continue
            labels = readers.setdefault(f"${name}", [])
            if step.label not in labels:
                labels.append(step.label)
            seen.setdefault(name, step.environ.get(name))
    return seen, {key: ",".join(labels) for key, labels in readers.items()}


def _readers(observations: StepObservations, keep: Callable[[str], bool],
             tracked: Collection[str], where: Where) -> dict[str, str]:
    """Each path a step read that its build system does not watch itself (not in `tracked`)
    -> the labels of the steps that read it; a file of the package's own by its name among
    them (a `file(READ)` at configure time: CMake does not watch it either)."""
    readers: dict[str, list[str]] = {}

    def read(path: str, label: str) -> None:
        labels = readers.setdefault(path, [])
        if label not in labels:
            labels.append(label)

    for step in observations.steps:
        observation = step.observation
        for paths in (observation.reads, observation.listings, observation.searches):
            for path in paths:
                read(path, step.label)
        # a path looked at or for is held in its directory's probes
        for path in observation.present | observation.absent:
            path = path.rstrip("/") or "/"
            read(path if where.own_name(path) else path.rpartition("/")[0] or "/",
                 step.label)
    found: dict[str, str] = {}
    for path, labels in readers.items():
        if path in tracked:
            continue
        name = path if keep(path) else where.own_name(path)
        if name is not None:
            found[name] = ",".join(labels)
    return found


def _probes(paths: Iterable[str], held: Collection[str]) -> dict[str, list[str]]:
    """The paths looked at or for, by directory (those whose content or listing is held
    anyway left out)."""
    probes: dict[str, list[str]] = {}
    for path in paths:
        path = path.rstrip("/") or "/"
        if path in held or path == "/":
            continue
        directory, _, name = path.rpartition("/")
        if name in ("", ".", ".."):
            continue
        probes.setdefault(directory or "/", []).append(name)
    return probes


def _tree(root: str) -> list[str]:
    """Every directory below `root` (a tree a step walked)."""
    return [directory for directory, _, _ in os.walk(root, followlinks=False)]


def _globbed(pattern: str) -> list[str]:
    """The directories a glob(3) of `pattern` lists: each one its leading directories match."""
    parts = pattern.split("/")
    fixed = next((i for i, part in enumerate(parts) if globbing.has_magic(part)), len(parts))
    if fixed >= len(parts):
        return []
    base = "/".join(parts[:fixed]) or "/"
    found = [base]
    for index in range(fixed + 1, len(parts)):
        middle = "/".join(parts[:index])
        found.extend(d for d in globbing.glob(middle) if os.path.isdir(d))
    return found
