"""A package's new record (record/model.py) at the end of its job: after a build (what its
steps were observed to read, builder/observations.py), after a restore (the entry's record,
with this machine's signatures) and after early cutoff (the last record, with its
dependencies' new keys).

From what a build's steps were observed to do, the record keeps what lies outside what the
package itself makes and owns:
- left out: what the steps wrote, the package's build directory, its stage and its install
  prefix (its outputs), the machine's running state (`/proc`, `/sys`, `/dev`), and the paths
  inside the package its own files already hold (record/own_files.py: a read below a name
  the own files leave out, `.git` or `__pycache__`, is kept);
- a compiled Python module read is held by its source (observe/log.py);
- a tree a step walked (fts, nftw) counts as every directory below it listed, a glob(3) as
  the directories its pattern lists;
- a path looked at or looked for is held in its directory's probes (what is there now), but
  one whose content or listing is held anyway."""

from __future__ import annotations

import glob as globbing
import os
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from wsbuild.build_types import ReadOutside
from wsbuild.builder.observations import StepObservations
from wsbuild.builder.plan import PackagePlan
from wsbuild.observe.log import merged
from wsbuild.record.dirty import Environment, changed_read
from wsbuild.record.environment import held, names_digest, variable_digests
from wsbuild.record.installed import Installed
from wsbuild.record.model import PENDING, PackageRecord, read_record
from wsbuild.record.outside import Digests, own_entries, refreshed, take
from wsbuild.record.own_files import LEFT_OUT

#: the machine's running state, never a file's content
PSEUDO = ("/proc/", "/sys/", "/dev/")


def dependency_keys(planned: PackagePlan, build_base: Path) -> dict[str, str]:
    """The keys of the package's workspace dependencies as this run leaves them: the plan's,
    and for those it built or restored before this package, their new records'."""
    keys = {}
    for dep, key in planned.now.dependencies.items():
        if key.startswith(PENDING):
            record = read_record(build_base / dep)
            key = record.key if record is not None else key
        keys[dep] = key
    return keys


@dataclass(frozen=True, slots=True)
class Where:
    """Where a package's build happened: what is its own and what it makes."""

    source_dir: Path
    own: Collection[str]
    #: its build directory, stage and (isolated) install prefix
    outputs: tuple[Path, ...]
    install_base: Path
    #: directories whose reads are a tool's own state (a compiler cache's storage)
    tool_state: tuple[Path, ...] = ()

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


def built_record(planned: PackagePlan, *, observations: StepObservations,
                 declared: ReadOutside | Sequence[str] | None,
                 dependencies: Mapping[str, str], installed: Sequence[Installed],
                 where: Where, environment: Environment, digests: Digests, started_ns: int,
                 test_tree: bool = False, volatile: str = "",
                 compiler_variables: Sequence[str] = ()) -> PackageRecord:
    """The record of a package just built: what the plan saw, its dependencies' keys, and what
    its steps were observed to read (with what the build type declares its in-process steps
    read, `declared`). A path that changed while the package built is held as racy
    (record/outside.py). `compiler_variables`: read by the compiles of a step that compiled
    where nothing is observed (sccache's server)."""
    if declared is not None and not isinstance(declared, ReadOutside):
        declared = ReadOutside(files=tuple(declared))  # a third-party type's list of files
    observation = merged(step.observation for step in observations.steps)
    keep = where.keeper()
    files = {p for p in observation.reads if keep(p)}
    listings = {p for p in observation.listings if keep(p)}
    listings.update(d for root in observation.trees if keep(root) for d in _tree(root))
    listings.update(d for pattern in observation.globs for d in _globbed(pattern) if keep(d))
    if declared is not None:
        files.update(p for p in map(os.path.normpath, declared.files) if keep(p))
        listings.update(p for p in map(os.path.normpath, declared.listings) if keep(p))
    searches = {d: p for d, p in observation.searches.items() if keep(d) and d not in listings}
    probes = _probes((p for p in observation.present | observation.absent if keep(p)),
                     held=files | listings | set(searches))
    installed_entries = own_entries(str(where.install_base), installed)
    reads = take(files, listings, digests, searches=searches, probes=probes,
                 started_ns=started_ns, own=installed_entries)
    names, seen, read_by = _variables(observations, compiler_variables)
    if observation.every_variable:
        names |= {n for step in observations.steps for n, v in step.environ.items()
                  if v is not None}
    ignored = (*environment.ignored, *observations.run_only)
    read_by.update(_first_readers(observations, keep))
    return planned.record(
        dependencies=dependencies, outside=reads, complete=observation.complete,
        installed=installed, test_tree=test_tree,
        environment=variable_digests(environment.environ, names,
                                     own_install=environment.own_install, ignored=ignored),
        environment_seen=variable_digests(seen, names, own_install=environment.own_install,
                                          ignored=ignored),
        environment_names=names_digest(environment.environ, ignored=ignored)
        if observation.variable_names else "",
        unobserved=observation.unobserved, volatile=volatile, read_by=read_by)


def _variables(observations: StepObservations, compiler_variables: Sequence[str]
               ) -> tuple[set[str], dict[str, str | None], dict[str, str]]:
    """The variables the steps read, the value each had for the first step that read it,
    and `$NAME` -> that step's label."""
    names: set[str] = set()
    seen: dict[str, str | None] = {}
    read_by: dict[str, str] = {}
    for step in observations.steps:
        read = set(step.observation.variables)
        if compiler_variables and step.label == "build":
            read.update(compiler_variables)
        for name in sorted(read):
            if not held(name) or name in names:
                continue
            names.add(name)
            seen[name] = step.environ.get(name)
            read_by[f"${name}"] = step.label
    return names, seen, read_by


def _first_readers(observations: StepObservations, keep: object) -> dict[str, str]:
    """Each path a step read -> the label of the first step that read it."""
    first: dict[str, str] = {}
    for step in observations.steps:
        observation = step.observation
        for paths in (observation.reads, observation.listings, observation.searches):
            for path in paths:
                first.setdefault(path, step.label)
    return {p: label for p, label in first.items() if keep(p)}  # type: ignore[operator]


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


def restored_record(planned: PackagePlan, entry: PackageRecord,
                    installed: Sequence[Installed], *, install_base: Path,
                    digests: Digests) -> PackageRecord:
    """The record of a package restored from the build cache: the entry's, with this
    machine's signatures of the package's files and of what the entry read outside (proved
    the same here) and the installed files."""
    return replace(entry, own=planned.own.files,
                   outside=refreshed(entry.outside, digests,
                                     own=own_entries(str(install_base), installed)),
                   installed=tuple(installed)).sealed()


def cut_off_record(planned: PackagePlan, dependencies: Mapping[str, str], *,
                   install_base: Path, digests: Digests,
                   environment: Environment) -> PackageRecord | None:
    """The record a package keeps when nothing it read of its dependencies (built before it
    in this run) changed (early cutoff), with their new keys; None when something did (it is
    then built). `environment`: what its steps would see now, its dependencies' hooks
    applied (a dependency's hook may set a variable it reads)."""
    previous = planned.previous
    if previous is None:
        return None
    if changed_read(previous, digests=digests, install_base=install_base, planning=False,
                    environment=environment, seen=True) is not None:
        return None
    own = own_entries(str(install_base), previous.installed)
    return replace(previous, dependencies=dict(dependencies),
                   dependency_inputs=dict(planned.dependency_inputs),
                   outside=refreshed(previous.outside, digests, own=own)).sealed()
