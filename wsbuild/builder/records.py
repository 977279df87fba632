"""A package's new record (record/model.py) at the end of its job: after a build (what its
steps were observed to read, record/observed.py), after a restore (the entry's record, with
this machine's signatures) and after early cutoff (the last record, with its dependencies'
new keys)."""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TypeVar

from wsbuild.build_types import ReadOutside
from wsbuild.builder.plan import PackagePlan
from wsbuild.observe.steps import StepObservations
from wsbuild.record.dirty import Environment, changed_read
from wsbuild.record.environment import names_digest, variable_digests
from wsbuild.record.installed import Installed
from wsbuild.record.model import PENDING, PackageRecord, read_record
from wsbuild.record.observed import Where, observed_reads
from wsbuild.record.outside import Digests, OutsideReads, own_entries, refreshed

T = TypeVar("T")


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


def built_record(planned: PackagePlan, *, observations: StepObservations,
                 declared: ReadOutside | Sequence[str] | None,
                 dependencies: Mapping[str, str], installed: Sequence[Installed],
                 where: Where, install_base: Path, environment: Environment, digests: Digests,
                 started_ns: int, test_tree: bool = False, volatile: str = "",
                 compiler_variables: Sequence[str] = (),
                 earlier: PackageRecord | None = None, afresh: Collection[str] = (),
                 touched: Mapping[str, str] | None = None) -> PackageRecord:
    """The record of a package just built: what the plan saw, its dependencies' keys, and what
    its steps were observed to read (with what the build type declares its in-process steps
    read and what its build system watches itself, `declared`). A path that changed while
    the package built is held as racy (record/outside.py). `compiler_variables`: read by the
    compiles of its build step, where nothing is observed (sccache's server). `earlier`: the
    last record, when this build reused what the last one left (an incremental CMake build:
    what the compiles that did not run again read still counts), but what only the steps
    it ran `afresh` read. `touched`: files whose time
    the build set forward, with their digest then (record/outside.py's racy rule)."""
    if declared is not None and not isinstance(declared, ReadOutside):
        declared = ReadOutside(files=tuple(declared))  # a third-party type's list of files
    declared = declared or ReadOutside()
    reads = observed_reads(
        observations, where, digests, files=declared.files, listings=declared.listings,
        tracked=set(declared.files) | set(declared.listings), started_ns=started_ns,
        own=own_entries(str(install_base), installed, package=planned.name,
                        keep=dependencies), settled=touched,
        extra_variables={"build": compiler_variables} if compiler_variables else None)
    ignored = (*environment.ignored, *observations.run_only)
    names = set(reads.seen)
    values = variable_digests(environment.environ, names, own_install=environment.own_install,
                              ignored=ignored)
    seen_values = variable_digests(reads.seen, names, own_install=environment.own_install,
                                   ignored=ignored)
    outside, read_by = reads.outside, reads.read_by
    if earlier is not None:
        outside, values, seen_values, read_by = _with_earlier(
            earlier, outside, values, seen_values, read_by, afresh)
    listed_names = reads.observation.variable_names or (
        earlier is not None and bool(earlier.environment_names))
    return planned.record(
        dependencies=dependencies, outside=outside, complete=reads.observation.complete,
        installed=installed, test_tree=test_tree, environment=values,
        environment_seen=seen_values,
        environment_names=names_digest(environment.environ, ignored=ignored)
        if listed_names else "",
        unobserved=reads.observation.unobserved, volatile=volatile, read_by=read_by)


def _with_earlier(earlier: PackageRecord, reads: OutsideReads, values: dict[str, str],
                  seen: dict[str, str], read_by: dict[str, str], afresh: Collection[str]
                  ) -> tuple[OutsideReads, dict[str, str], dict[str, str], dict[str, str]]:
    """What an incremental build read, with what the earlier builds whose work it reused
    read and it did not read again (unchanged since, or this build would have redone the
    step that read it). What only the steps this build ran `afresh` read before no longer
    counts (a configure from a fresh cache, a build of everything: they read again what
    they need), nor does the build system's earlier list of what it watches (`reads` holds
    that list as this build left it)."""
    labels: dict[str, str] = {}
    gone: set[str] = set()
    for read, by in earlier.read_by.items():
        kept = [label for label in by.split(",") if label not in afresh]
        if kept:
            labels[read] = ",".join(kept)
        else:
            gone.add(read)
    for read, by in read_by.items():
        before = labels[read].split(",") if read in labels else []
        labels[read] = ",".join(dict.fromkeys([*before, *by.split(",")]))

    def still(entries: Mapping[str, T]) -> dict[str, T]:
        # an earlier entry no step is named for was the build system's own list (what it
        # watches, `tracked`): this build's list replaces it whole (a file deleted since is
        # in neither the list nor a step's reads)
        return {path: value for path, value in entries.items()
                if path not in gone and path in earlier.read_by}

    old = earlier.outside
    merged_reads = OutsideReads({**still(old.files), **reads.files},
                                {**still(old.listings), **reads.listings},
                                {**still(old.searches), **reads.searches},
                                {**still(old.probes), **reads.probes})
    variables = {f"${name}" for name in earlier.environment} & gone
    return (merged_reads,
            {**{n: v for n, v in earlier.environment.items() if f"${n}" not in variables},
             **values},
            {**{n: v for n, v in earlier.environment_seen.items() if f"${n}" not in variables},
             **seen}, labels)


def restored_record(planned: PackagePlan, entry: PackageRecord,
                    installed: Sequence[Installed], *, install_base: Path,
                    digests: Digests) -> PackageRecord:
    """The record of a package restored from the build cache: the entry's, with this
    machine's signatures of the package's files and of what the entry read outside (proved
    the same here) and the installed files."""
    return replace(entry, own=planned.own.files,
                   outside=refreshed(entry.outside, digests,
                                     own=own_entries(str(install_base), installed,
                                                     package=entry.package,
                                                     keep=entry.dependencies)),
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
    own = own_entries(str(install_base), previous.installed, package=previous.package,
                      keep=previous.dependencies)
    return replace(previous, dependencies=dict(dependencies),
                   dependency_inputs=dict(planned.dependency_inputs),
                   outside=refreshed(previous.outside, digests, own=own)).sealed()
