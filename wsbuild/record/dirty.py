"""The one dirty check: whether a package's record still holds for the package as it is now,
and if not, why (cargo's `DirtyReason`). The plan, early cutoff, the build cache and
`--dry-run` all ask it; a cached test result is asked in the same words (record/tested.py),
which are record/reason.py's."""

from __future__ import annotations

import json
import os
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.record.environment import (changed_names, names_digest, variable_digests,
                                        variables_changed)
from wsbuild.record.environment import held as is_held
from wsbuild.record.installed import damaged_install
from wsbuild.record.model import PENDING, PackageRecord
from wsbuild.record.outside import Digests, changed_paths, first_change, own_entries
from wsbuild.record.own_files import OwnFiles, files_digest
from wsbuild.record.reason import Dirty, Reason


@dataclass(frozen=True, slots=True)
class Environment:
    """The environment a package's steps would start from now, before its dependencies'
    hooks (observe/step_environment.py's `step_base` of the run's), as records compare it."""

    environ: Mapping[str, str]
    #: the workspace's install base (record/environment.py's normalization)
    own_install: str = ""
    #: the variables the user says never matter (`--env-ignore`)
    ignored: tuple[str, ...] = ()

    #: what was worked out of `environ` (which does not change): a variable's digest (None:
    #: never held), and "" the digest of the names set; a plan asks the same of every package
    _known: dict[str, str | None] = field(default_factory=dict, compare=False, repr=False)

    def digests(self, names: Iterable[str]) -> dict[str, str]:
        known = self._known
        wanted = sorted(set(names))
        missing = [name for name in wanted if name not in known]
        if missing:
            found = variable_digests(self.environ, missing, own_install=self.own_install,
                                     ignored=self.ignored)
            known.update((name, found.get(name)) for name in missing)
        return {name: digest for name in wanted if (digest := known[name]) is not None}

    def names(self) -> str:
        digest = self._known.get("")
        if digest is None:
            digest = self._known[""] = names_digest(self.environ, ignored=self.ignored)
        return digest


@dataclass(frozen=True, slots=True)
class PackageNow:
    """A package as it is now: what its record is compared with."""

    own: OwnFiles
    settings: Mapping[str, object]
    environment: Environment
    #: the keys its workspace dependencies have (after this run, where known)
    dependencies: Mapping[str, str]


def environment_change(record: PackageRecord, environment: Environment, *,
                       seen: bool = False) -> tuple[str, ...]:
    """The variables the record's steps read whose value differs now (`seen`: compared with
    what the steps saw, their dependencies' hooks applied, and `environment` is such)."""
    held = {name: digest for name, digest in
            (record.environment_seen if seen else record.environment).items()
            if is_held(name, environment.ignored)}  # what the user ignores now, too
    now = environment.digests(held)
    changed = tuple(changed_names(held, now))
    if record.environment_names and environment.names() != record.environment_names:
        changed += ("(the set of variables)",)
    return changed


def _redo(record: PackageRecord, changed: Iterable[str]) -> tuple[str, ...]:
    """The labels of the steps that read what changed, where no build system watches it."""
    return tuple(dict.fromkeys(label for c in changed if c in record.read_by
                               for label in record.read_by[c].split(",")))


def dirty_reason(old: PackageRecord | None, now: PackageNow, *, install_base: Path,
                 digests: Digests, unfinished: bool = False, forced: bool = False,
                 pending: Collection[str] = ()) -> Reason | None:
    """None when the record `old` holds for the package `now`, else why not. `pending`: the
    dependencies this run builds or restores before the package; `unfinished`: its last
    build was cut short; `forced`: the command line asks for a build."""
    if unfinished:
        return Reason(Dirty.UNFINISHED, "the previous build did not finish")
    if forced:
        return Reason(Dirty.FORCED, "forced")
    if old is None:
        return Reason(Dirty.NEW, "no previous build")
    if old.settings != now.settings:
        changed = tuple(settings_changes(old.settings, now.settings))
        return Reason(Dirty.OPTIONS, "build options changed: " + "; ".join(changed), changed)
    changed_variables = environment_change(old, now.environment)
    if changed_variables:
        return variables_changed(changed_variables,
                                 redo=_redo(old, (f"${name}" for name in changed_variables)))
    if (old.own_digest or files_digest(old.own)) != now.own.digest:  # by content, not stat
        changed = now.own.changed or sorted(set(old.own) ^ set(now.own.files))
        shown = ", ".join(changed[:3]) + (" …" if len(changed) > 3 else "")
        return Reason(Dirty.SOURCE, f"source changed: {shown}" if shown else "source changed",
                      tuple(changed), redo=_redo(old, changed))
    changed_deps = sorted(n for n in set(old.dependencies) | set(now.dependencies)
                          if old.dependencies.get(n) != now.dependencies.get(n))
    always = _always(old)
    # early cutoff: a rebuilt dependency matters only through what this build read of it, when
    # all its steps read was observed
    cutoff = always is None and set(old.dependencies) == set(now.dependencies)
    if changed_deps and not cutoff:
        return Reason(Dirty.DEPENDENCY, "dependency rebuilt: " + ", ".join(changed_deps),
                      tuple(changed_deps))
    waiting = [n for n in changed_deps if n in pending]
    if waiting:
        return Reason(Dirty.DEPENDENCY, f"dependency {', '.join(waiting)} is built first; this "
                      "package only if what it read of it changes", tuple(waiting), cutoff=True)
    own = own_entries(str(install_base), old.installed, package=old.package,
                      keep=old.dependencies)
    outside = first_change(old.outside, digests, planning=True, own=own)
    if outside is not None:
        changed = tuple(changed_paths(old.outside, digests, planning=True, own=own))
        redo = _redo(old, changed)
        if changed_deps:
            return Reason(Dirty.DEPENDENCY, "dependency rebuilt: " + ", ".join(changed_deps)
                          + f" (read while building: {outside})", tuple(changed_deps),
                          redo=redo)
        return Reason(Dirty.EXTERNAL, f"file outside the package changed: {outside}",
                      changed or (outside,), redo=redo)
    damaged = damaged_install(str(install_base), old.installed, digests)
    if damaged is not None:
        return Reason(Dirty.INSTALL, f"install damaged: {damaged} missing or changed", (damaged,))
    return always


def _always(record: PackageRecord) -> Reason | None:
    """Why a package's build system runs every time, whatever changed: its steps were not all
    observed, or its build system had work left right after its build."""
    if not record.complete:
        why = "; ".join(record.unobserved[:2]) or "its steps were not observed"
        return Reason(Dirty.UNOBSERVED, f"not fully observed, so built every time ({why})",
                      record.unobserved)
    if record.volatile:
        return Reason(Dirty.VOLATILE, f"its build system always has work ({record.volatile})",
                      (record.volatile,))
    return None


def changed_read(record: PackageRecord, *, digests: Digests, install_base: Path,
                 planning: bool, dependencies: Mapping[str, str] | None = None,
                 waiting: bool = False, environment: Environment | None = None,
                 seen: bool = False) -> Reason | None:
    """What a record's build read that is not so here, None when all is (the part of the check
    an entry of the build cache and early cutoff ask, their own files and settings being
    proved by the inputs key): a record whose steps were not all observed, or whose build
    system always has work, never holds; with `dependencies`, the keys the package's
    dependencies have here (a PENDING one is not compared: its build in this run decides);
    with `environment`, the variables its steps read (`seen`: as they saw them, their
    dependencies' hooks applied); then the files, listings, searches and probes outside the
    package (`waiting`: some dependency is yet to be built or restored in this run, so what it
    read in the install base is compared later)."""
    always = _always(record)
    if always is not None:
        return always
    if dependencies is not None:
        for dep, key in sorted(dependencies.items()):
            if not key.startswith(PENDING) and record.dependencies.get(dep) != key:
                return Reason(Dirty.DEPENDENCY, f"built against another build of {dep}", (dep,))
        if set(record.dependencies) != set(dependencies):
            return Reason(Dirty.DEPENDENCY, "built against other dependencies",
                          tuple(sorted(set(record.dependencies) ^ set(dependencies))))
    if environment is not None:
        changed_variables = environment_change(record, environment, seen=seen)
        if changed_variables:
            return Reason(Dirty.ENVIRONMENT, f"read {', '.join(changed_variables[:5])}, which "
                          "differs here", changed_variables,
                          redo=_redo(record, (f"${n}" for n in changed_variables)))
    own = own_entries(str(install_base), record.installed, package=record.package,
                      keep=record.dependencies)
    changed = first_change(record.outside, digests, planning=planning, own=own,
                           skip=str(install_base) + os.sep if waiting else "")
    if changed is not None:
        return Reason(Dirty.EXTERNAL, f"read {changed}, which differs here", (changed,),
                      redo=_redo(record, (changed,)))
    return None


def cutoff_note(old: PackageRecord | None, dependencies: Mapping[str, str]) -> str:
    """Why a package whose dependencies were rebuilt is still up to date ("" when none was)."""
    if old is None:
        return ""
    changed = sorted(n for n in dependencies if old.dependencies.get(n) != dependencies[n])
    if not changed:
        return ""
    return (f"dependency {', '.join(changed)} rebuilt; nothing this package builds from "
            "changed → up to date")


def settings_changes(old: Mapping[str, object], new: Mapping[str, object]) -> list[str]:
    """`name: old → new` for each setting that differs (options by their own name)."""
    def flat(values: Mapping[str, object]) -> dict[str, object]:
        result: dict[str, object] = {}
        for key, value in values.items():
            if isinstance(value, Mapping):
                result.update({str(k): v for k, v in value.items()})
            else:
                result[key] = value
        return result

    # as the record keeps them (tuples become lists), so only real differences show
    before, after = flat(json.loads(json.dumps(old))), flat(json.loads(json.dumps(new)))
    return [f"{name}: {_shown(before.get(name))} → {_shown(after.get(name))}"
            for name in sorted(set(before) | set(after)) if before.get(name) != after.get(name)]


def _shown(value: object) -> str:
    if value is None:
        return "(none)"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(str(v) for v in value) + "]"
    return str(value)
