"""The plan of a build, made once before anything runs: for every selected package the decision
(up to date, restore from the build cache, build), the reason, the build key it will have, the
cache key, the inputs, the start order and the critical path — and whether the build must
refuse to start. `build --dry-run` prints it; `build` executes it (builder/pipeline.py); neither
decides anything else. Planning touches nothing in install/ or log/; it writes its memos only
(the dependency check's answers, the records' memo: not under --dry-run)."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.build_types import BuildOptions, Step, type_key_options, type_options
from wsbuild.builder import bookkeeping
from wsbuild.builder.bookkeeping import BuilderStep
from wsbuild.builder.overrides import Override, overrides_to_warn
from wsbuild.builder.request import BuildRequest, PackageOptions
from wsbuild.engine.ready_queue import JobGraph, start_order
from wsbuild.errors import DependencyError
from wsbuild.record.dirty import Dirty, PackageNow, Reason, cutoff_note, dirty_reason
from wsbuild.record.installed import Installed
from wsbuild.record.model import PENDING, PackageRecord, inputs_key, read_record
from wsbuild.record.outside import OutsideReads, own_entries, refreshed
from wsbuild.record.own_files import OwnFiles, own_files
from wsbuild.session import Session
from wsbuild.workspace.selection import Selection
from wsbuild import __version__
from wsbuild import inputs as declared
from wsbuild.prefix.layout import is_installed, package_prefix

if TYPE_CHECKING:
    from wsbuild.cache.key import CacheKey
    from wsbuild.cache.run import Proven

#: created when a package build starts, removed when it finished: an interrupted build is redone
BUILDING_MARKER = Path(".wsbuild") / "building"
#: what the marker holds when the build it marks failed (empty: it was cut short)
FAILED_MARK = "failed\n"


class Decision(Enum):
    UP_TO_DATE = "up to date"
    RESTORE = "restore"
    BUILD = "build"


@dataclass(frozen=True, slots=True)
class ShardWait:
    """Another shard builds it: waited for until `seconds` after the start, then restored."""

    owner: str
    seconds: float


@dataclass(frozen=True, slots=True)
class PackagePlan:
    """One package's part of the plan: its decision, why, and what its build gets."""

    name: str
    build_type: str
    decision: Decision
    #: why it is restored or built; None: up to date
    reason: Reason | None
    #: the package's key once this run is done, where the plan knows it (up to date, or a
    #: restore whose dependencies are known); else PENDING + its inputs key
    key: str
    #: what decides its output that is known before its build reads anything (its own files,
    #: settings, environment, its dependencies' inputs keys): the build cache finds it by this
    inputs_key: str
    #: where it is installed: install/<pkg>, or install/ when merged
    prefix: Path
    #: the package as it is now (own files, settings, environment, dependencies' keys), which
    #: its record is compared with and which its new record holds
    now: PackageNow
    #: its workspace dependencies' inputs keys (what `inputs_key` holds of them)
    dependency_inputs: Mapping[str, str]
    #: under which the build cache keeps it (None: cache off)
    cache_key: CacheKey | None = None
    #: the entry to restore, proved while planning (decision RESTORE)
    cache_entry: Proven | None = None
    #: the package's source directory, which the own files' paths are relative to
    source_dir: Path = Path()
    #: source files whose content changed but whose modification time did not advance
    backdated: tuple[str, ...] = ()
    #: why an up-to-date package whose dependencies were rebuilt is still up to date (its
    #: record then becomes `cut_off`)
    note: str = ""
    #: what the last build recorded (a package to build or restore, or one cut off)
    previous: PackageRecord | None = None
    #: the record an up-to-date package whose dependencies were rebuilt keeps (early cutoff)
    cut_off: PackageRecord | None = None
    #: what its build gets beyond the run's options (colcon.meta's); only these of all
    #: packages' own options enter its key
    options: PackageOptions = PackageOptions()
    #: a package to build or restore: its build type's steps, decided from the context the
    #: builder makes for it (builder/context.py), and the environment they start from; the
    #: build runs these, `--dry-run` prints them
    steps: tuple[Step, ...] = ()
    step_environ: Mapping[str, str] = field(default_factory=dict)
    #: the builder's own steps before and after them (builder/bookkeeping.py)
    before: tuple[BuilderStep, ...] = ()
    after: tuple[BuilderStep, ...] = ()
    wait: ShardWait | None = None  # another shard builds it (builder/shards/run.py)

    @property
    def own(self) -> OwnFiles:
        return self.now.own

    def record(self, *, dependencies: Mapping[str, str], outside: OutsideReads | None = None,
               complete: bool = False, installed: Sequence[Installed] = (),
               test_tree: bool = False, environment: Mapping[str, str] | None = None,
               environment_seen: Mapping[str, str] | None = None, environment_names: str = "",
               unobserved: Sequence[str] = (), volatile: str = "",
               read_by: Mapping[str, str] | None = None) -> PackageRecord:
        """The record of this package built now: what the plan saw, its dependencies' keys as
        their builds left them, and what its steps read (record/model.py)."""
        return PackageRecord(
            package=self.name, build_type=self.build_type, own=self.now.own.files,
            settings=self.now.settings, environment=dict(environment or {}),
            environment_seen=dict(environment_seen or {}), environment_names=environment_names,
            dependencies=dict(sorted(dependencies.items())),
            dependency_inputs=dict(sorted(self.dependency_inputs.items())),
            outside=outside if outside is not None else OutsideReads(),
            complete=complete, unobserved=tuple(unobserved), volatile=volatile,
            read_by=dict(read_by or {}), installed=tuple(installed),
            test_tree=test_tree).sealed()


@dataclass(frozen=True, slots=True)
class Refusal:
    """Why the build would not start (exit 2): the error, and a short line for the dry run."""

    error: DependencyError
    summary: str


@dataclass(frozen=True, slots=True)
class BuildPlan:
    """What a build does: each selected package's plan, in start order, and the run's options."""

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


@dataclass(slots=True)
class _Planning:
    """What planning one package needs of the run and of the packages planned before it."""

    selection: Selection
    request: BuildRequest
    options: BuildOptions
    session: Session
    underlay: Mapping[str, list[str]]
    #: the workspace's output bases: nothing inside them is a package's own file
    outputs: tuple[str, ...]
    #: each workspace package's key after this run as far as known (PENDING + inputs key
    #: until built), and its inputs key; dependencies outside the selection are added as read
    keys: dict[str, str] = field(default_factory=dict)
    inputs_keys: dict[str, str] = field(default_factory=dict)
    #: the packages this run builds or restores
    pending: set[str] = field(default_factory=set)
    #: each build type's key options of each set of options, as JSON values
    key_options: dict[tuple[str, BuildOptions], object] = field(default_factory=dict)
    #: the C/C++ compiler launcher the build will use (--compiler-cache), decided when a
    #: package first needs building
    launcher: str | None = None
    #: package -> the workspace packages whose install its last build read (its record's)
    read_installs: dict[str, tuple[str, ...]] = field(default_factory=dict)


def _edges(selection: Selection, read_installs: Mapping[str, Sequence[str]]
           ) -> dict[str, set[str]]:
    """What each selected package waits for: its declared dependencies, and the packages
    whose install its last build read without declaring them (record/undeclared.py), where
    they come before it in the declared order (no cycle)."""
    selected = set(selection.selected)
    position = {name: index for index, name in enumerate(selection.selected)}
    edges: dict[str, set[str]] = {}
    for name in selection.selected:
        found = selection.graph.direct(name) & selected
        found |= {dep for dep in read_installs.get(name, ())
                  if dep in selected and position[dep] < position[name]}
        edges[name] = found
    return edges


def make_plan(selection: Selection, request: BuildRequest, session: Session, *,
              priorities: Mapping[str, float] | None = None) -> BuildPlan:
    """What `wsbuild build` will do with `selection`, package by package, and why.
    `priorities`: the weights the scheduler ranks packages by, when not their own recorded
    times (a shard's: each package's work in the whole split, builder/shards/run.py)."""
    from wsbuild.builder.weights import package_weights  # lazy: off `test` and `test --shard`

    ws = selection.workspace
    # the arguments the underlay needs (its Python, libpython's link flags, the linters'
    # stand-ins) reach the build types that declare them (build_types/cmake_options.py)
    options = request.build.with_values({"underlay_cmake_args": session.underlay.cmake_args})
    not_built = unbuilt_dependencies(selection, session.merged)
    unresolved = _unresolved(selection, request, session)
    overrides = overrides_to_warn(selection.selected, selection.packages,
                                  request.allow_overriding, session.environ, ws.install_base)
    planning = _Planning(selection, request, options, session,
                         underlay_paths(str(ws.install_base), session.environ),
                         tuple(str(base) for base in (ws.build_base, ws.install_base,
                                                      ws.log_base)))
    # in topological order, so a dependent sees the key its dependency will have after this run
    packages: list[PackagePlan] = []
    for name in selection.selected:
        planned = plan_package(planning, name)
        planning.keys[name] = planned.key
        planning.inputs_keys[name] = planned.inputs_key
        if planned.decision is not Decision.UP_TO_DATE:
            planning.pending.add(name)
        packages.append(planned)
    jobs = JobGraph.of(selection.selected, _edges(selection, planning.read_installs))
    weights = package_weights(selection.packages, selection.selected, ws.build_base) \
        if priorities is None else priorities
    path = jobs.critical_path(weights)
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


def plan_package(planning: _Planning, name: str) -> PackagePlan:
    """One package's decision: its record compared with the package as it is now (the one
    dirty check, record/dirty.py), then, when it must be built, whether the build cache holds
    an entry this machine can prove (cache/run.py)."""
    selection, session = planning.selection, planning.session
    package = selection.packages[name]
    own_options = planning.request.packages.get(name, PackageOptions())
    build_dir = selection.workspace.build_base / name
    old = read_record(build_dir)
    if old is not None and old.installs_read:
        planning.read_installs[name] = old.installs_read
    own = own_files(package.path, old.own if old else {}, planning.outputs)
    prefix = _prefix(selection, session, name)
    settings = package_settings(package.build_type, own_options.applied_to(planning.options),
                                prefix, planning.underlay, planning.key_options)
    closure = selection.graph.build_closure(name)
    _read_dependencies(planning, closure)
    now = PackageNow(own, settings, session.environment,
                     {dep: planning.keys[dep] for dep in sorted(closure)})
    dependency_inputs = {dep: planning.inputs_keys[dep] for dep in sorted(closure)}
    request = planning.request
    forced = request.force or _forced_by_option(package.build_type, request.build)
    unfinished = declared.exists(build_dir / BUILDING_MARKER)
    reason = dirty_reason(old, now, install_base=selection.workspace.install_base,
                          digests=session.digests, unfinished=unfinished,
                          forced=forced, pending=planning.pending)
    if unfinished and reason is not None:
        reason = _unfinished_reason(reason, build_dir, dirty_reason(
            old, now, install_base=selection.workspace.install_base, digests=session.digests,
            forced=forced, pending=planning.pending))
    common = dict(name=name, build_type=package.build_type, prefix=prefix, now=now,
                  dependency_inputs=dependency_inputs, source_dir=package.path,
                  options=own_options)
    if reason is None and old is not None:
        note = cutoff_note(old, now.dependencies)
        if not note:  # its record holds: its keys are the record's
            return PackagePlan(decision=Decision.UP_TO_DATE, reason=None, key=old.key,
                               inputs_key=old.inputs_key, **common)
        # early cutoff: its dependencies were rebuilt, nothing it read of them changed; it
        # takes the key its record now gives (its dependents then decide for themselves)
        kept = replace(old, dependencies=dict(now.dependencies),
                       dependency_inputs=dependency_inputs,
                       outside=refreshed(old.outside, session.digests,
                                         own=own_entries(str(selection.workspace.install_base),
                                                         old.installed, package=old.package,
                                                         keep=old.dependencies))).sealed()
        return PackagePlan(decision=Decision.UP_TO_DATE, reason=None, key=kept.key,
                           inputs_key=kept.inputs_key, note=note, previous=old, cut_off=kept,
                           **common)
    assert reason is not None
    before = inputs_key(name, package.build_type, own.digest, settings, dependency_inputs)
    common["inputs_key"] = before
    common["backdated"] = _backdated(old, own)
    common["previous"] = old
    cache_key = session.cache.key(name, package.build_type, before)
    found = None
    if cache_key is not None and reason.kind is not Dirty.FORCED:
        found = session.cache.lookup(cache_key, before, now.dependencies, session.digests,
                                     waiting=bool(closure & planning.pending))
    common["steps"], common["step_environ"] = _steps(planning, name, prefix, own_options,
                                                     redo=reason.redo)
    common["before"] = bookkeeping.before(compiler_cache=bool(planning.launcher),
                                          built_before=old is not None)
    common["after"] = bookkeeping.AFTER
    if found is not None:
        known = all(not key.startswith(PENDING) for key in now.dependencies.values())
        key = found.record.key if known else PENDING + before
        return PackagePlan(decision=Decision.RESTORE, reason=reason, key=key,
                           cache_key=cache_key, cache_entry=found, **common)
    return PackagePlan(decision=Decision.BUILD, reason=reason, key=PENDING + before,
                       cache_key=cache_key, **common)


def _unfinished_reason(reason: Reason, build_dir: Path, other: Reason | None) -> Reason:
    """The reason of a package whose last build did not end well: whether it failed or was
    cut short, and what else changed since its record (changed options, sources)."""
    try:
        failed = declared.read_text(build_dir / BUILDING_MARKER) == FAILED_MARK
    except OSError:
        failed = False
    text = "the previous build failed" if failed else "the previous build did not finish"
    if other is not None:
        text += f"; and {other.text}"
    return replace(reason, text=text, details=other.details if other is not None else ())


def _steps(planning: _Planning, name: str, prefix: Path, own_options: PackageOptions, *,
           redo: tuple[str, ...] = ()) -> tuple[tuple[Step, ...], Mapping[str, str]]:
    """The steps of a package to build (or to restore: a refused entry builds it), decided as
    the build decides them (builder/context.py), with the compiler launcher the build will
    use; and the environment they start from."""
    from wsbuild.builder.context import planned_steps  # lazy: off the full no-op build

    if planning.launcher is None:
        from wsbuild.builder.resources.compiler_cache import (
            planned_launcher)  # lazy: off the full no-op build

        planning.launcher = planned_launcher(planning.request.compiler_cache,
                                             planning.session.environ,
                                             distributing=planning.request.distribute is not None)
    options = replace(own_options.applied_to(planning.options),
                      compiler_launcher=planning.launcher)
    return planned_steps(planning.selection, planning.session, name, prefix=prefix,
                         options=options, redo=redo,
                         distributing=planning.request.distribute is not None)


def _forced_by_option(build_type: str, options: BuildOptions) -> bool:
    """Whether an option of its build type given on the command line builds every package of
    it (--cmake-force-configure, --cmake-clean-cache, …)."""
    declared = type_options(build_type)
    return any(option.forces_build and options.value(option) for option in declared)


def _read_dependencies(planning: _Planning, closure: set[str]) -> None:
    """The keys of the workspace packages in `closure` that this run does not plan: as their
    records say (read once)."""
    for dep in closure - planning.keys.keys():
        record = read_record(planning.selection.workspace.build_base / dep)
        planning.keys[dep] = record.key if record is not None else "unknown"
        planning.inputs_keys[dep] = record.inputs_key if record is not None else "unknown"


def _backdated(old: PackageRecord | None, own: OwnFiles) -> tuple[str, ...]:
    """The changed files whose modification time is not after the one last built from."""
    if old is None:
        return ()
    return tuple(rel for rel in own.changed
                 if rel in old.own and rel in own.files
                 and own.files[rel].mtime_ns <= old.own[rel].mtime_ns)


def _prefix(selection: Selection, session: Session, name: str) -> Path:
    return package_prefix(selection.workspace.install_base, name, merged=session.merged)


def package_settings(build_type: str, options: BuildOptions, prefix: Path,
                     underlay: Mapping[str, list[str]],
                     memo: dict[tuple[str, BuildOptions], object] | None = None
                     ) -> dict[str, object]:
    """Everything besides files, the environment and dependencies that shapes a package's
    build, as its record holds it (JSON values). The build type says which options count
    (worked out once per build type and options with `memo`); `underlay` is
    `underlay_paths()` of the run."""
    memo = {} if memo is None else memo
    key_options = memo.get((build_type, options))
    if key_options is None:  # as JSON keeps them: tuples become lists
        key_options = memo[(build_type, options)] = json.loads(json.dumps(
            type_key_options(build_type, options)))
    return {
        "wsbuild": __version__,
        "build_type": build_type,
        "options": key_options,
        # the interpreter by its environment and version, not by how its path is spelled
        "python": [sys.prefix, sys.version],
        "ament_prefix_path": list(underlay["AMENT_PREFIX_PATH"]),
        "cmake_prefix_path": list(underlay["CMAKE_PREFIX_PATH"]),
        "install_prefix": str(prefix),
    }


def underlay_paths(own: str, environ: Mapping[str, str]) -> dict[str, list[str]]:
    """AMENT_PREFIX_PATH and CMAKE_PREFIX_PATH without this workspace's own prefixes (there when
    its setup.bash is sourced: they are not an underlay). Worked out once per plan, not once
    per package: a sourced workspace of 1,000 packages puts 1,000 prefixes on each."""
    return {var: [p for p in environ.get(var, "").split(os.pathsep)
                  if p and not p.startswith(own)]
            for var in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH")}


def unbuilt_dependencies(selection: Selection, merged: bool) -> dict[str, list[str]]:
    """Workspace packages that selected ones need but that are neither selected nor installed:
    dependency -> the selected packages needing it, sorted by name."""
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
    from wsbuild.builder.unresolved import unresolved  # lazy: off `test` and `test --shard`
    from wsbuild.workspace.resolve import Resolver  # lazy: off `test` and `test --shard`

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
