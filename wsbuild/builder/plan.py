"""The plan of a build, made once before anything runs: for every selected package the decision
(up to date, restore from the build cache, build), the reason, the build key it will have, the
cache key, the inputs, the start order and the critical path — and whether the build must
refuse to start. `build --dry-run` prints it; `build` executes it (builder/pipeline.py); neither
decides anything else. Planning touches nothing in install/ or log/; what it writes is its
memos: the dependency check's answers (build/.wsbuild/unresolved.json, not under --dry-run), the
compilers' versions (toolchain.json in the build cache's directory) and a cache entry's use
time when it looks one up."""

from __future__ import annotations

import os
import sys
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.build_types import BuildOptions, environment_digests, get_build_type
from wsbuild.builder.fingerprint import BuildState, Reason, SourceSnapshot
from wsbuild.builder.overrides import Override
from wsbuild.builder.request import BuildRequest, PackageOptions
from wsbuild.engine.ready_queue import JobGraph, start_order
from wsbuild.errors import DependencyError
from wsbuild.session import Session
from wsbuild.workspace.selection import Selection
from wsbuild import inputs as declared

if TYPE_CHECKING:
    from wsbuild.cache.client import Found
    from wsbuild.cache.key import CacheKey

#: created when a package build starts, removed when it finished: an interrupted build is redone
BUILDING_MARKER = Path(".wsbuild") / "building"


class Decision(Enum):
    UP_TO_DATE = "up to date"
    RESTORE = "restore"
    BUILD = "build"


@dataclass(frozen=True, slots=True)
class PackagePlan:
    name: str
    build_type: str
    decision: Decision
    #: why it is restored or built; None: up to date
    reason: Reason | None
    #: the package's build key once this run is done (what its dependents build against)
    key: str
    #: where it is installed: install/<pkg>, or install/ when merged
    prefix: Path
    #: what `settings` digests: the options, interpreter and underlay that shape the build
    inputs: Mapping[str, object]
    settings: str
    dependency_keys: Mapping[str, str]
    snapshot: SourceSnapshot
    #: under which the build cache keeps it (None: cache off)
    cache_key: CacheKey | None = None
    #: the entry to restore (decision RESTORE)
    cache_entry: Found | None = None
    #: the package's source directory, which the snapshot's paths are relative to
    snapshot_root: Path = Path()
    #: source files whose content changed but whose modification time did not advance
    backdated: tuple[str, ...] = ()
    #: why an up-to-date package whose dependencies were rebuilt is still up to date (its
    #: state then becomes `cut_off_state()`)
    note: str = ""
    #: what the last build recorded (a package to build or restore, or one cut off)
    previous: BuildState | None = None
    #: what its build gets beyond the run's options (colcon.meta's); only these of all
    #: packages' own options enter its key
    options: PackageOptions = PackageOptions()

    def cut_off_state(self) -> BuildState:
        """The state of a package early cutoff keeps: what it last recorded, with the key and
        dependency keys of this run and its outside files' signatures as they are now."""
        from wsbuild.builder.fingerprint import external_signatures

        assert self.previous is not None
        return replace(self.previous, key=self.key, dependencies=dict(self.dependency_keys),
                       external=external_signatures(self.previous.external))


@dataclass(frozen=True, slots=True)
class Refusal:
    """Why the build would not start (exit 2): the error, and a short line for the dry run."""

    error: DependencyError
    summary: str


@dataclass(frozen=True, slots=True)
class BuildPlan:
    #: the options every package is built with (the request's, with the underlay's CMake args);
    #: a package's own (`PackagePlan.options`) come after them
    options: BuildOptions
    #: in the order the build starts them with one worker: the up-to-date ones (settled
    #: before any job starts), then the others as the scheduler's ready queue hands them out
    packages: tuple[PackagePlan, ...]
    #: the selected packages (topological order) with their dependencies within the selection
    jobs: JobGraph
    weights: Mapping[str, float]
    #: the heaviest chain (dependencies first) and its weight in seconds
    critical_path: tuple[str, ...]
    critical_seconds: float
    #: package -> its build dependencies that nothing provides (the build warns)
    unresolved: Mapping[str, tuple[str, ...]]
    #: workspace package neither selected nor built -> the selected packages needing it
    not_built: Mapping[str, tuple[str, ...]]
    overrides: tuple[Override, ...]
    refusal: Refusal | None
    notices: tuple[str, ...]

    def to_do(self) -> list[PackagePlan]:
        """The packages the build restores or builds, in the order it starts them."""
        return [p for p in self.packages if p.decision is not Decision.UP_TO_DATE]

    def jobs_to_do(self) -> JobGraph:
        """The scheduler's jobs: the packages to restore or build, with the edges among them."""
        return self.jobs.subset({p.name for p in self.to_do()})


def make_plan(selection: Selection, request: BuildRequest, session: Session) -> BuildPlan:
    """What `wsbuild build` will do with `selection`, package by package, and why."""
    from wsbuild.builder.overrides import overrides_to_warn
    from wsbuild.builder.weights import package_weights

    ws = selection.workspace
    options = replace(request.build, underlay_cmake_args=session.underlay.cmake_args)
    selected = set(selection.selected)
    not_built = unbuilt_dependencies(selection, session.merged)
    unresolved = _unresolved(selection, request, session)
    overrides = overrides_to_warn(selection.selected, selection.packages,
                                  request.allow_overriding, session.environ, ws.install_base)
    jobs = JobGraph.of(selection.selected,
                       {n: selection.graph.direct(n) & selected for n in selection.selected})
    weights = package_weights(selection.packages, selection.selected, ws.build_base)
    path = jobs.critical_path(weights)
    underlay = underlay_paths(str(ws.install_base), session.environ)
    # in topological order, so a dependent sees the key its dependency will have after this run
    keys: dict[str, str] = {}
    packages: list[PackagePlan] = []
    pending: set[str] = set()
    #: the outside files' signatures, each taken once (packages share most of them)
    seen: dict[str, tuple[int, ...]] = {}
    for name in selection.selected:
        planned = plan_package(selection, request, options, session, name, keys, underlay,
                               pending, seen)
        keys[name] = planned.key
        if planned.decision is not Decision.UP_TO_DATE:
            pending.add(name)
        packages.append(planned)
    return BuildPlan(
        options=options,
        packages=start_ordered(packages, jobs, weights),
        jobs=jobs,
        weights=weights,
        critical_path=tuple(path),
        critical_seconds=sum(weights.get(n, 0.0) for n in path),
        unresolved=unresolved,
        not_built={dep: tuple(users) for dep, users in not_built.items()},
        overrides=tuple(overrides),
        refusal=_refusal(not_built, unresolved, request.strict_dependencies),
        notices=session.notices,
    )


def plan_package(selection: Selection, request: BuildRequest, options: BuildOptions,
                 session: Session, name: str, keys: dict[str, str],
                 underlay: Mapping[str, list[str]], pending: Collection[str] = (),
                 seen: dict[str, tuple[int, ...]] | None = None) -> PackagePlan:
    """One package's decision, from its recorded state, its sources and its dependencies'
    keys (`keys`: what each workspace package's key is after this run, as far as known;
    dependencies outside the selection are added as they are read; `pending`: the packages
    this run builds or restores)."""
    from wsbuild.builder.fingerprint import cutoff_note, digest_of, read_state, snapshot_sources

    package = selection.packages[name]
    own = request.packages.get(name, PackageOptions())
    old = read_state(selection.workspace.build_base / name)
    snapshot = snapshot_sources(package.path, old.files if old else {})
    prefix = _prefix(selection, session, name)
    inputs = package_inputs(selection, own.applied_to(options), name, prefix, underlay,
                            session.environ)
    settings = digest_of(inputs)
    dep_keys = dependency_keys(selection, selection.graph.build_closure(name), keys)
    reason = rebuild_reason(selection, request, name, old, snapshot, settings, dep_keys, inputs,
                            pending, seen)
    common = dict(name=name, build_type=package.build_type, prefix=prefix, inputs=inputs,
                  settings=settings, dependency_keys=dep_keys, snapshot=snapshot,
                  snapshot_root=package.path, options=own)
    if reason is None and old is not None:
        note = cutoff_note(old, dep_keys)
        if not note:
            return PackagePlan(decision=Decision.UP_TO_DATE, reason=None, key=old.key, **common)
    key = BuildState.make_key(snapshot.digest, settings, dep_keys)
    if reason is None and old is not None:
        # early cutoff: its dependencies were rebuilt, nothing it read of them changed; it
        # takes the key its inputs now give (its dependents then decide for themselves)
        return PackagePlan(decision=Decision.UP_TO_DATE, reason=None, key=key, note=note,
                           previous=old, **common)
    common["backdated"] = _backdated(old, snapshot)
    common["previous"] = old
    cache_key = session.cache.key(name, package.build_type, key, prefix, session.environ)
    found = None
    if cache_key is not None and reason is not None and reason.kind != "forced":
        found = session.cache.lookup(cache_key)
    decision = Decision.RESTORE if found is not None else Decision.BUILD
    return PackagePlan(decision=decision, reason=reason, key=key, cache_key=cache_key,
                       cache_entry=found, **common)


def _backdated(old: BuildState | None, snapshot: SourceSnapshot) -> tuple[str, ...]:
    """The changed files whose modification time is not after the one last built from."""
    if old is None:
        return ()
    return tuple(rel for rel in snapshot.changed
                 if rel in old.files and rel in snapshot.files
                 and snapshot.files[rel].mtime_ns <= old.files[rel].mtime_ns)


def _prefix(selection: Selection, session: Session, name: str) -> Path:
    from wsbuild.prefix.layout import package_prefix

    return package_prefix(selection.workspace.install_base, name, merged=session.merged)


def package_inputs(selection: Selection, options: BuildOptions, name: str, prefix: Path,
                   underlay: Mapping[str, list[str]],
                   environ: Mapping[str, str]) -> dict[str, object]:
    """Everything besides sources and dependencies that shapes a package's build (recorded
    with the build, to name what changed). The build type says which options and environment
    variables count; `underlay` is `underlay_paths()` of the run."""
    from wsbuild import __version__

    build_type = selection.packages[name].build_type
    kind = get_build_type(build_type)
    return {
        "wsbuild": __version__,
        "build_type": build_type,
        "options": kind.key_options(options),
        # by digest: a value is never written (state.json keeps these inputs)
        "environment": environment_digests(environ, getattr(kind, "key_environment", ())),
        # the interpreter by its environment and version, not by how its path is spelled
        "python": [sys.prefix, sys.version],
        "ament_prefix_path": underlay["AMENT_PREFIX_PATH"],
        "cmake_prefix_path": underlay["CMAKE_PREFIX_PATH"],
        "install_prefix": str(prefix),
    }


def underlay_paths(own: str, environ: Mapping[str, str]) -> dict[str, list[str]]:
    """AMENT_PREFIX_PATH and CMAKE_PREFIX_PATH without this workspace's own prefixes (there when
    its setup.bash is sourced: they are not an underlay). Worked out once per plan, not once
    per package: a sourced workspace of 1,000 packages puts 1,000 prefixes on each."""
    return {var: [p for p in environ.get(var, "").split(os.pathsep)
                  if p and not p.startswith(own)]
            for var in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH")}


def dependency_keys(selection: Selection, closure: set[str],
                    keys: dict[str, str]) -> dict[str, str]:
    """The build keys of the workspace packages a package builds against (its `closure`):
    planned in this run, else as last built (read once, then kept in `keys`)."""
    from wsbuild.builder.fingerprint import read_state

    for dep in closure - keys.keys():
        state = read_state(selection.workspace.build_base / dep)
        keys[dep] = state.key if state is not None else "unknown"
    return {dep: keys[dep] for dep in sorted(closure)}


def rebuild_reason(selection: Selection, request: BuildRequest, name: str,
                   old: BuildState | None, snapshot: SourceSnapshot, settings: str,
                   dep_keys: Mapping[str, str], inputs: Mapping[str, object],
                   pending: Collection[str] = (),
                   seen: dict[str, tuple[int, ...]] | None = None) -> Reason | None:
    """Why `name` must be built (None: up to date)."""
    from wsbuild.builder.fingerprint import rebuild_reason as compare

    options = request.build
    if declared.exists(selection.workspace.build_base / name / BUILDING_MARKER):
        return Reason("unfinished", "the previous build did not finish")
    if request.force or options.cmake_force_configure or options.cmake_clean_cache \
            or options.cmake_clean_first:
        return Reason("forced", "forced")
    return compare(old, snapshot, settings, dep_keys, selection.workspace.install_base, inputs,
                   pending, seen)


def unbuilt_dependencies(selection: Selection, merged: bool) -> dict[str, list[str]]:
    """Workspace packages that selected ones need but that are neither selected nor installed:
    dependency -> the selected packages needing it, sorted by name."""
    from wsbuild.prefix.layout import is_installed

    selected = set(selection.selected)
    install_base = selection.workspace.install_base
    not_built: dict[str, list[str]] = {}
    for name in selection.selected:
        for dep in sorted(selection.graph.build_closure(name)):
            if dep not in selected and not is_installed(install_base, dep, merged=merged):
                not_built.setdefault(dep, []).append(name)
    return dict(sorted(not_built.items()))


def _unresolved(selection: Selection, request: BuildRequest,
                session: Session) -> dict[str, tuple[str, ...]]:
    """Package -> its build dependencies nothing provides (workspace/resolve.py), remembered
    while the environment holds (builder/unresolved.py)."""
    if request.skip_dependency_check:
        return {}
    from wsbuild.builder.unresolved import unresolved
    from wsbuild.workspace.resolve import Resolver

    resolver = Resolver.from_environment(
        session.environ, session.underlay_prefixes,
        memo=selection.workspace.build_base / ".wsbuild" / "pkg_config.json",
        remember=not session.options.dry_run)
    return unresolved((selection.packages[n] for n in selection.selected), selection.packages,
                      resolver, selection.workspace.build_base,
                      remember=not session.options.dry_run)


def _refusal(not_built: Mapping[str, Sequence[str]], unresolved: Mapping[str, Sequence[str]],
             strict: bool) -> Refusal | None:
    if not_built:
        items = "; ".join(f"{dep} (needed by {', '.join(users)})"
                          for dep, users in not_built.items())
        first_user = next(iter(not_built.values()))[0]
        message = f"workspace packages not built yet: {items}"
        return Refusal(DependencyError(
            message, hint=f"build them too, e.g. wsbuild build --packages-up-to {first_user}"),
            message)
    if unresolved and strict:
        users: dict[str, list[str]] = {}
        for name, deps in unresolved.items():
            for dep in deps:
                users.setdefault(dep, []).append(name)
        items = "; ".join(f"{dep} (needed by {', '.join(names)})"
                          for dep, names in sorted(users.items()))
        return Refusal(DependencyError(
            f"unresolved build dependencies: {items}",
            hint="install them into the underlay (e.g. pip install ros-jazzy-<name> or apt), "
            "source the underlay that has them, or build without --strict-dependencies"),
            "unresolved build dependencies (--strict-dependencies)")
    return None


def start_ordered(packages: Sequence[PackagePlan], jobs: JobGraph,
                  weights: Mapping[str, float]) -> tuple[PackagePlan, ...]:
    """`packages` in the order the build starts them with one worker: the up-to-date ones as
    given (the build settles them before any job), then the ones to restore or build in the
    order of the scheduler's ready queue (engine/ready_queue.py) over the same jobs and
    weights the build hands it (`BuildPlan.jobs_to_do`)."""
    by_name = {p.name: p for p in packages}
    settled = [p for p in packages if p.decision is Decision.UP_TO_DATE]
    to_do = jobs.subset({p.name for p in packages if p.decision is not Decision.UP_TO_DATE})
    return (*settled, *(by_name[name] for name in start_order(to_do, weights)))
