"""A package's new record (record/model.py) at the end of its job: after a build (what its
build system read outside the package), after a restore (the entry's record, with this
machine's signatures and environment) and after early cutoff (the last record, with its
dependencies' new keys)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

from wsbuild.build_types import ReadOutside
from wsbuild.builder.plan import PackagePlan
from wsbuild.record.dirty import changed_read
from wsbuild.record.model import PENDING, PackageRecord, read_record
from wsbuild.record.outside import Digests, own_entries, refreshed, take


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


def built_record(planned: PackagePlan, *, read: ReadOutside | Sequence[str] | None,
                 dependencies: Mapping[str, str], installed: Sequence[tuple[str, int]],
                 inside: Sequence[Path], install_base: Path, digests: Digests,
                 started_ns: int, test_tree: bool = False) -> PackageRecord:
    """The record of a package just built: what the plan saw, its dependencies' keys, and what
    its build system says it read outside (`read`; None: it cannot tell), less what lies
    `inside` the package, its build directory and its stage. A path that changed while the
    package built is held as racy (record/outside.py)."""
    if read is None:
        return planned.record(dependencies=dependencies, installed=installed,
                              test_tree=test_tree)
    if not isinstance(read, ReadOutside):  # a third-party type's list of files
        read = ReadOutside(files=tuple(read))
    prefixes = tuple(os.path.normpath(directory) + os.sep for directory in inside)

    def outside(paths: Sequence[str]) -> list[str]:
        normal = (os.path.normpath(p) for p in paths if os.path.isabs(p))
        return [p for p in normal if not (p + os.sep).startswith(prefixes)]

    reads = take(outside(read.files), outside(read.listings), digests, started_ns=started_ns,
                 own=own_entries(str(install_base), installed))
    return planned.record(dependencies=dependencies, outside=reads, complete=True,
                          installed=installed, test_tree=test_tree)


def restored_record(planned: PackagePlan, entry: PackageRecord,
                    installed: Sequence[tuple[str, int]], *, install_base: Path,
                    digests: Digests) -> PackageRecord:
    """The record of a package restored from the build cache: the entry's, with this
    machine's signatures of the package's files and of what the entry read outside (proved
    the same here), this run's environment and the installed files."""
    return replace(entry, own=planned.own.files, environment=planned.now.environment,
                   outside=refreshed(entry.outside, digests,
                                     own=own_entries(str(install_base), installed)),
                   installed=tuple(installed)).sealed()


def cut_off_record(planned: PackagePlan, dependencies: Mapping[str, str], *,
                   install_base: Path, digests: Digests) -> PackageRecord | None:
    """The record a package keeps when nothing it read of its dependencies (built before it
    in this run) changed (early cutoff), with their new keys; None when something did (it is
    then built)."""
    previous = planned.previous
    if previous is None:
        return None
    if changed_read(previous, digests=digests, install_base=install_base,
                    planning=False) is not None:
        return None
    own = own_entries(str(install_base), previous.installed)
    return replace(previous, dependencies=dict(dependencies),
                   dependency_inputs=dict(planned.dependency_inputs),
                   outside=refreshed(previous.outside, digests, own=own)).sealed()
