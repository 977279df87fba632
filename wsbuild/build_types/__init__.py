"""Build types: one module per `<build_type>` string, registered through one entry-point group.

A build type owns everything wsbuild knows about its packages, so nothing outside this room
asks which build type a package has:
- `steps(ctx)`: the recipe, a short list of labelled steps (configure, build, install, ...),
  each a value (`Step`): a command (argv, cwd, the environment it sets) the engine runs, or a
  small in-process action with a description; both print (`--dry-run`, reproduce lines);
- `test_runner`: how its tests run and what their results say (test_runner.py; pytest's in
  build_types/pybuild/tests.py, CTest's in ctest.py), or None when its packages have none;
- `hooks`: what its packages' environment needs (`prefix.hooks.EnvironmentHooks`);
- `key_options(options)`: the build options that shape its output (they enter the build key);
- `estimate_base`: the scheduler's guess of its cost before any build was recorded.
Everything a step touches (paths, environment, options, subprocesses) comes from the
`BuildContext`, so a unit test can hand in a recording fake; what a step reports back goes into
the typed `BuildOutputs`. The built-in types register through the same entry-point group
(`wsbuild.build_types`, in pyproject.toml) as another distribution's: `BuildTypeBase` gives a
third-party type the defaults.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from importlib.metadata import EntryPoint

    from wsbuild.build_types.test_runner import TestRunner

from wsbuild.errors import ManifestError, WsbuildError
from wsbuild.prefix.hooks import EnvironmentHooks
from wsbuild.workspace.model import Package

ENTRY_POINT_GROUP = "wsbuild.build_types"

#: The built-in build types, as pyproject.toml registers them in the entry-point group (a test
#: holds the two equal). Discovery knows these names, and they load as entry points, without
#: scanning every installed distribution's metadata: that costs tens of milliseconds in a ROS
#: venv, on every run.
BUILTIN_ENTRY_POINTS = {
    "ament_cmake": "wsbuild.build_types.ament_cmake:BUILD_TYPE",
    "ament_python": "wsbuild.build_types.ament_python:BUILD_TYPE",
    "cmake": "wsbuild.build_types.cmake:BUILD_TYPE",
    "python": "wsbuild.build_types.python:BUILD_TYPE",
}
BUILTIN = tuple(BUILTIN_ENTRY_POINTS)


@dataclass(frozen=True, slots=True)
class BuildOptions:
    """The options of `wsbuild build` that reach a package's build."""

    symlink_install: bool = False
    merge_install: bool = False
    cmake_args: tuple[str, ...] = ()
    #: CMake arguments for ament_cmake packages only, after `cmake_args` (--ament-cmake-args)
    ament_cmake_args: tuple[str, ...] = ()
    cmake_target: str | None = None
    cmake_clean_cache: bool = False
    cmake_clean_first: bool = False
    cmake_force_configure: bool = False
    #: parallel compile jobs this package may use (its share of the CPU budget)
    jobs: int = 1
    python_executable: str = ""
    #: CMake arguments the underlay needs (e.g. the wheel venv's Python and libpython flags);
    #: they come before the user's --cmake-args, so the user's win
    underlay_cmake_args: tuple[str, ...] = ()
    #: compiler cache (sccache/ccache executable) CMake runs compilers through; "" for none
    compiler_launcher: str = ""


class StepFailed(Exception):
    """Raised by `BuildContext.run` (or a step) when a command fails."""

    def __init__(self, message: str, *, command: Sequence[str] = (), cwd: Path | None = None,
                 env_delta: Mapping[str, str] | None = None, returncode: int | None = None) -> None:
        super().__init__(message)
        self.command = tuple(command)
        self.cwd = cwd
        self.env_delta = dict(env_delta or {})
        self.returncode = returncode


#: picks, from a command's stderr lines, the ones worth showing as the package's warnings
Problems = Callable[[list[str]], list[str]]


class Runner(Protocol):
    def __call__(self, command: Sequence[str], *, cwd: Path,
                 env: Mapping[str, str] | None = None, problems: Problems | None = None) -> None: ...


@dataclass(frozen=True, slots=True)
class ReadOutside:
    """What a build read outside its package, as its build system lists it (absolute paths;
    what lies inside the package, its build directory or its stage is left out by the
    builder): files, whose content counts, and directories whose entries it listed (a glob),
    whose entries count."""

    files: tuple[str, ...] = ()
    listings: tuple[str, ...] = ()


@dataclass(slots=True)
class BuildOutputs:
    """What a package's steps report back to the build (typed; nothing else is passed back)."""

    #: files (relative to the prefix) an install wrote into the prefix directly instead of the
    #: stage (ament's symlink install into a merged prefix); the merged record keeps them
    installed_in_place: tuple[str, ...] = ()
    #: what the build read outside the package; None: the build cannot tell
    read_outside: ReadOutside | None = None


@dataclass(slots=True)
class BuildContext:
    """What a build type gets to work with. `stage_prefix` becomes `install_prefix` on success."""

    package: Package
    build_dir: Path
    install_prefix: Path
    stage_prefix: Path
    options: BuildOptions
    #: full environment for subprocesses (dependencies' prefixes already applied)
    environ: dict[str, str]
    #: runs a command, logs it and its output; raises StepFailed on non-zero exit
    run: Runner
    #: records a warning shown in the package's report
    warn: Callable[[str], None]
    #: install prefixes of the package's build dependencies inside the workspace
    dependency_prefixes: tuple[Path, ...] = ()
    #: the run's jobserver as a named FIFO, for clients that speak only that form (Ninja);
    #: `environ["MAKEFLAGS"]` holds the file-descriptor form GNU make 4.3 understands
    jobserver_fifo: Path | None = None
    outputs: BuildOutputs = field(default_factory=BuildOutputs)

    @property
    def source_dir(self) -> Path:
        return self.package.path


@dataclass(frozen=True, slots=True)
class Command:
    """A program to run: what a step runs, or what reproduces an in-process step by hand."""

    argv: tuple[str, ...]
    cwd: Path
    #: variables the command sets on top of the package's environment (its dependencies'
    #: prefixes applied); they are printed in `--dry-run` and in reproduce lines
    env: Mapping[str, str] = field(default_factory=dict)
    #: variables set for this run only and never printed: they name a stage or a jobserver
    #: that do not exist outside the run (DESTDIR of a stage, Ninja's jobserver FIFO)
    run_env: Mapping[str, str] = field(default_factory=dict)
    #: picks the warnings among its stderr lines (None: every line)
    problems: Problems | None = None


@dataclass(frozen=True, slots=True)
class Step:
    """One labelled step of a build type's recipe, as data: the engine runs it, `--dry-run`
    prints it. Either a `command`, or an in-process `action` (`Step(label, action)`, the form
    a third-party type may keep) with a `description` of what it does; `by_hand`, when known,
    is the command that does the same from a shell. `before`, `around` and `after` are
    in-process bookkeeping around the command (the stage, a configure record) that a by-hand
    run does not need."""

    label: str
    action: Callable[[BuildContext], None] | None = None
    command: Command | None = None
    description: str = ""
    by_hand: Command | None = None
    before: Callable[[BuildContext], None] | None = None
    around: Callable[[BuildContext], AbstractContextManager[None]] | None = None
    after: Callable[[BuildContext], None] | None = None
    #: what it reads and writes, where known (informational: printed by `--dry-run --json`)
    reads: tuple[Path, ...] = ()
    writes: tuple[Path, ...] = ()

    def __post_init__(self) -> None:
        if (self.action is None) == (self.command is None):
            raise ValueError(f"step '{self.label}' needs either a command or an action")

    @property
    def shown(self) -> Command | None:
        """The command a person runs for this step: its own, or its by-hand equivalent."""
        return self.command if self.command is not None else self.by_hand


class BuildType(Protocol):
    """What a build type's entry point loads (the built-ins: `BUILD_TYPE` of their module)."""

    name: str
    #: how its packages' tests run (None: they have none)
    test_runner: TestRunner | None
    hooks: EnvironmentHooks
    estimate_base: float

    def steps(self, ctx: BuildContext) -> list[Step]:
        """The labelled steps that build and stage the package."""
        ...

    def key_options(self, options: BuildOptions) -> dict[str, object]:
        """The options that shape what this build type installs (they enter the build key)."""
        ...

    def external_inputs(self, ctx: BuildContext) -> ReadOutside | list[str] | None:
        """After a build: what its build system read outside the package (from the build
        system's own dependency lists), recorded in the package's record so that a change to
        one rebuilds it; None when the build cannot tell (a dependency's rebuild then always
        rebuilds the package). A plain list names files. Optional for a third-party type
        (BuildTypeBase: what its steps put in `ctx.outputs.read_outside`, else None)."""
        ...


#: options that change how a build runs, never what it installs
_RUN_ONLY_OPTIONS = ("jobs", "compiler_launcher")
#: options only CMake reads
_CMAKE_OPTIONS = ("cmake_args", "ament_cmake_args", "cmake_target", "cmake_clean_cache",
                  "cmake_clean_first", "cmake_force_configure", "underlay_cmake_args")


class RunnerNamed:
    """A build type's test runner named by `module:attribute` and imported when first asked
    for, so that a build, which runs no test, imports no runner. The built-ins name theirs so:
    `test_runner = RunnerNamed("wsbuild.build_types.ctest:CTEST")`."""

    def __init__(self, target: str) -> None:
        self.target = target

    def __get__(self, instance: object, owner: type | None = None) -> TestRunner | None:
        if instance is None:  # asked of the class (the entry-point check): import nothing
            return self  # type: ignore[return-value]
        return _load_entry_point(self.target)  # type: ignore[return-value]


@dataclass(frozen=True, slots=True)
class BuildTypeBase:
    """Defaults for a build type: no tests, a plain prefix's hooks, CMake options ignored.
    Subclass it and override what differs (`name` and `steps` at least)."""

    name: str = ""
    hooks: EnvironmentHooks = EnvironmentHooks()
    estimate_base: float = 0.3

    @property
    def test_runner(self) -> TestRunner | None:
        """No tests; a subclass names its runner as a field, or with `RunnerNamed` (the
        built-ins: a build that runs no test imports no runner)."""
        return None

    def steps(self, ctx: BuildContext) -> list[Step]:
        raise NotImplementedError(f"build type '{self.name}' defines no steps")

    def key_options(self, options: BuildOptions) -> dict[str, object]:
        return {k: v for k, v in asdict(options).items()
                if k not in _RUN_ONLY_OPTIONS and k not in _CMAKE_OPTIONS}

    def external_inputs(self, ctx: BuildContext) -> ReadOutside | list[str] | None:
        """What the steps reported reading outside the package (`ctx.outputs.read_outside`:
        the Python builds' setup.py, by an audit hook), else None."""
        return ctx.outputs.read_outside


def cmake_key_options(options: BuildOptions) -> dict[str, object]:
    """The key options of a CMake project: every option but the run-only ones."""
    return {k: v for k, v in asdict(options).items() if k not in _RUN_ONLY_OPTIONS}


_loaded: dict[str, BuildType] = {}


def known_build_types() -> tuple[str, ...]:
    """Names of every registered build type (built-ins without importing them)."""
    names = set(BUILTIN)
    names.update(ep.name for ep in _entry_points())
    return tuple(sorted(names))


def is_known(name: str) -> bool:
    return name in BUILTIN or any(ep.name == name for ep in _entry_points())


def get_build_type(name: str) -> BuildType:
    """Load the build type registered under `name`; a broken plugin fails loudly."""
    if name in _loaded:
        return _loaded[name]
    if name in BUILTIN:
        value = BUILTIN_ENTRY_POINTS[name]
        loaded = _load_entry_point(value)
    else:
        matches = [ep for ep in _entry_points() if ep.name == name]
        if not matches:
            raise ManifestError(
                f"unknown build type '{name}'",
                hint="known build types: " + ", ".join(known_build_types()),
            )
        value = matches[0].value
        loaded = matches[0].load()
    build_type = _checked(loaded, name, value)
    _loaded[name] = build_type
    return build_type


def _load_entry_point(value: str) -> object:
    """What `module:attribute` names, loaded as importlib.metadata.EntryPoint.load() does
    (without importing importlib.metadata, which a no-op build need not pay for)."""
    import importlib

    module, _, attribute = value.partition(":")
    loaded: object = importlib.import_module(module)
    for part in attribute.split(".") if attribute else ():
        loaded = getattr(loaded, part)
    return loaded


_REQUIRED = ("name", "steps", "test_runner", "hooks", "estimate_base", "key_options")


def _checked(loaded: object, name: str, value: str) -> BuildType:
    """What an entry point loaded must be a whole build type: else an error naming it."""
    # the class first: asking the instance would run a property (a runner imported on a build)
    missing = [attr for attr in _REQUIRED
               if not hasattr(type(loaded), attr) and not hasattr(loaded, attr)]
    if missing or getattr(loaded, "name", None) != name:
        why = f"lacks {', '.join(missing)}" if missing else \
            f"is named {getattr(loaded, 'name', None)!r}"
        raise WsbuildError(
            f"build type '{name}' ({value}, entry point group {ENTRY_POINT_GROUP}) {why}",
            hint="derive it from wsbuild.build_types.BuildTypeBase and set name to the entry "
            "point's name, or uninstall the distribution that provides it",
        )
    return loaded  # type: ignore[return-value]


def _entry_points() -> Sequence[EntryPoint]:
    from importlib.metadata import entry_points

    return [ep for ep in entry_points(group=ENTRY_POINT_GROUP) if ep.name not in BUILTIN]


class KnownBuildTypes(Collection[str]):
    """Built-in names answer at once; plugin entry points are scanned only for other names."""

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and is_known(name)

    def __iter__(self) -> Iterator[str]:
        return iter(known_build_types())

    def __len__(self) -> int:
        return len(list(iter(self)))
