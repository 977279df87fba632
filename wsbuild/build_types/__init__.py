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
`PackageContext`, so a unit test can hand in a recording fake; what a step reports back goes into
the typed `BuildOutputs`. The built-in types register through the same entry-point group
(`wsbuild.build_types`, in pyproject.toml) as another distribution's: `BuildTypeBase` gives a
third-party type the defaults.

Over 500 lines because it is the whole boundary a third-party build type meets, in one place:
the protocol, the data it is handed and hands back, its defaults and its registration.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from wsbuild.build_types.plugins import Entry
    from wsbuild.build_types.pybuild.recipe import PythonBuildPlan
    from wsbuild.build_types.test_runner import TestRunner
    from wsbuild.record.dirty import Reason

from wsbuild.build_types.plugins import BUILD_TYPES, entries, load_value
from wsbuild.build_types.step_observer import StepObserver
from wsbuild.errors import ManifestError, WsbuildError
from wsbuild.prefix.hooks import EnvironmentHooks
from wsbuild.workspace.model import Package

__all__ = ["StepObserver"]  # re-exported: the context's `observe` is one

ENTRY_POINT_GROUP = "wsbuild.build_types"  # build_types/plugins.py: BUILD_TYPES

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
#: The options the built-in types declare (their `options`, a test holds them equal), named so
#: that the command line's parser reads them without importing the build types.
BUILTIN_OPTIONS = {
    "cmake": "wsbuild.build_types.cmake_options:CMAKE_OPTIONS",
    "ament_cmake": "wsbuild.build_types.cmake_options:AMENT_CMAKE_OPTIONS",
}


#: the kinds of value a build type's option holds: `switch` (given or not), `value` (one
#: string; None when not given), `arguments` (a list handed through to a tool, which may begin
#: with '-': `--cmake-args -DX=1 --`; () when not given)
OPTION_KINDS = ("switch", "value", "arguments")


@dataclass(frozen=True, slots=True)
class TypeOption:
    """An option of `wsbuild build` that a build type declares (`BuildType.options`), as
    colcon's tasks declare theirs (`add_arguments`), but as data: the command line, `--help`,
    the defaults files and mixins take it from here, its value reaches the packages of the
    types that declare it (`BuildOptions.value`), and it enters their key when it shapes what
    they install."""

    #: the long option ("--cmake-args"); "" for a value the run sets (not on the command line)
    flag: str
    #: its name in `BuildOptions` and in a package's record (flag without dashes, '_' for '-')
    dest: str
    help: str = ""
    kind: str = "value"
    metavar: str = ""
    #: it shapes what the package installs: its value is in the package's record and key
    in_key: bool = True
    #: given, it builds every package of the types that declare it (--cmake-force-configure)
    forces_build: bool = False
    #: listed by --help-all only
    secondary: bool = False

    def __post_init__(self) -> None:
        if self.kind not in OPTION_KINDS:
            raise ValueError(f"option {self.flag or self.dest}: kind must be one of "
                             f"{', '.join(OPTION_KINDS)}, not {self.kind!r}")

    @property
    def default(self) -> object:
        return {"switch": False, "value": None, "arguments": ()}[self.kind]


@dataclass(frozen=True, slots=True)
class BuildOptions:
    """The options of `wsbuild build` that reach a package's build: the ones every build type
    reads, and (`type_values`) those build types declare for their own packages."""

    symlink_install: bool = False
    merge_install: bool = False
    #: parallel compile jobs this package may use (its share of the CPU budget)
    jobs: int = 1
    python_executable: str = ""
    #: compiler cache (sccache/ccache executable) CMake runs compilers through; "" for none
    compiler_launcher: str = ""
    #: the values of the build types' own options (`TypeOption`), by dest, sorted; lists as
    #: tuples (the options are hashable: planning works out a type's key options once)
    type_values: tuple[tuple[str, object], ...] = ()

    def value(self, option: TypeOption) -> object:
        """The value of a build type's `option`: as given, else its default."""
        for dest, value in self.type_values:
            if dest == option.dest:
                return value
        return option.default

    def with_values(self, values: Mapping[str, object]) -> BuildOptions:
        """These options with the type options of `values` (by dest) set; lists as tuples."""
        merged = dict(self.type_values)
        merged.update({dest: tuple(value) if isinstance(value, list) else value
                       for dest, value in values.items()})
        return replace(self, type_values=tuple(sorted(merged.items())))


class StepFailed(Exception):
    """Raised by `PackageContext.run` (or a step) when a command fails."""

    def __init__(self, message: str, *, command: Sequence[str] = (), cwd: Path | None = None,
                 env_delta: Mapping[str, str] | None = None, returncode: int | None = None) -> None:
        super().__init__(message)
        self.command = tuple(command)
        self.cwd = cwd
        self.env_delta = dict(env_delta or {})
        self.returncode = returncode


#: picks, from a command's stderr lines, the ones worth showing as the package's warnings
Problems = Callable[[list[str]], list[str]]


class CommandRunner(Protocol):
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
    #: the Python types' configure step: how their install step installs (python.py)
    python_plan: PythonBuildPlan | None = None


@dataclass(slots=True)
class PackageContext:
    """What a build type gets to work with for one package, made by one function
    (`package_context`, for the build, `--dry-run` and the by-hand commands alike).
    `stage_prefix` becomes `install_prefix` on success."""

    package: Package
    build_dir: Path
    install_prefix: Path
    stage_prefix: Path
    options: BuildOptions
    #: full environment for subprocesses (dependencies' prefixes already applied)
    environ: dict[str, str]
    #: runs a command, logs it and its output; raises StepFailed on non-zero exit
    run: CommandRunner
    #: records a warning shown in the package's report
    warn: Callable[[str], None]
    #: install prefixes of the package's build dependencies inside the workspace
    dependency_prefixes: tuple[Path, ...] = ()
    #: the run's jobserver as a named FIFO, for clients that speak only that form (Ninja);
    #: `environ["MAKEFLAGS"]` holds the file-descriptor form GNU make 4.3 understands
    jobserver_fifo: Path | None = None
    outputs: BuildOutputs = field(default_factory=BuildOutputs)
    #: what its build type found once for the whole run (`BuildType.run_facts`: the tools it
    #: runs, e.g. Ninja and its version)
    facts: object = None
    #: what its build type found in the build directory when the context was made
    #: (`BuildType.read_state`: e.g. CMake's cache and the last configure's record); the
    #: steps are decided from it, so `steps()` reads nothing itself
    state: object = None
    #: the labels of its last build's steps that read what changed since (its record's
    #: `read_by`): a build type redoes from there (CMake configures again when its configure
    #: step read a changed file or variable that CMake itself does not watch)
    redo: tuple[str, ...] = ()
    #: how its in-process steps have the processes they ask of a warm helper observed
    #: (None: not observed, a plan's or a by-hand command's context)
    observe: StepObserver | None = None
    #: records information worth a line (not a warning): the build sets it to the package's
    #: command.log and its Finished line
    note: Callable[[str], None] = field(default=lambda _text: None)

    @property
    def source_dir(self) -> Path:
        return self.package.path


def package_context(build_type: BuildType, *, package: Package, build_dir: Path,
                    install_prefix: Path, stage_prefix: Path, options: BuildOptions,
                    environ: Mapping[str, str], run: CommandRunner, warn: Callable[[str], None],
                    dependency_prefixes: Sequence[Path] = (), jobserver_fifo: Path | None = None,
                    facts: object = None, redo: Sequence[str] = (),
                    observe: StepObserver | None = None) -> PackageContext:
    """The one function that makes a package's context: the build's, `--dry-run`'s and the
    by-hand command's (builder/context.py works out the environment and options of the first
    two, by_hand.py takes them from its command line). The build type reads the state of the
    build directory here, once (`read_state`); `facts` are its run's (`run_facts`)."""
    return PackageContext(
        package=package, build_dir=build_dir, install_prefix=install_prefix,
        stage_prefix=stage_prefix, options=options, environ=dict(environ), run=run, warn=warn,
        dependency_prefixes=tuple(dependency_prefixes), jobserver_fifo=jobserver_fifo,
        facts=facts, state=build_type.read_state(build_dir),
        redo=tuple(redo), observe=observe)


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
    prints it. Either a `command`, or work wsbuild does in its own process (an `action`:
    `Step(label, action)`, with a `description` of it and, where it matters, what it reads
    and writes); `by_hand`, when known, is the command that does the same from a shell. The
    bookkeeping around a command (dropping a stale CMake cache, parking the previous install,
    moving an install into the stage, writing the configure record) is such a step of its
    own, so `--dry-run` shows it: `(in wsbuild) remove the cache of another generator: …`."""

    label: str
    action: Callable[[PackageContext], None] | None = None
    command: Command | None = None
    description: str = ""
    by_hand: Command | None = None
    #: what it reads and writes, where known (printed by `--dry-run`)
    reads: tuple[Path, ...] = ()
    writes: tuple[Path, ...] = ()
    #: why a step that runs only sometimes runs now (a configure: record/configured.py), in
    #: the words a package's build is explained in; printed by `--dry-run`
    why: Reason | None = None

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

    def steps(self, ctx: PackageContext) -> list[Step]:
        """The labelled steps that build and stage the package: decided from the context
        alone (its options, environment, `facts` and `state`), reading and running nothing."""
        ...

    #: the options of `wsbuild build` it declares for its packages (() for none)
    options: tuple[TypeOption, ...]

    def key_options(self, options: BuildOptions) -> dict[str, object]:
        """The options that shape what this build type installs (they enter the build key)."""
        ...

    def outside_reads(self, ctx: PackageContext) -> ReadOutside | list[str] | None:
        """After a build: what its build system read outside the package (from the build
        system's own dependency lists), recorded in the package's record so that a change to
        one rebuilds it; None when the build cannot tell (a dependency's rebuild then always
        rebuilds the package). A plain list names files. (BuildTypeBase: what its steps put
        in `ctx.outputs.read_outside`, else None.)"""
        ...

    def run_facts(self, environ: Mapping[str, str]) -> object:
        """What the type needs to know once per run (the tools it runs), handed to every
        package's context as `facts` (BuildTypeBase: none)."""
        ...

    def read_state(self, build_dir: Path) -> object:
        """What the type needs to know of a package's build directory, read once when its
        context is made, handed in as `state` (BuildTypeBase: nothing)."""
        ...

    #: the tool its build reads package.xml with when that tool refuses what wsbuild only
    #: warns about (workspace/model.py's `Package.refused`); "": none does
    manifest_reader: str

    def work_left(self, ctx: PackageContext) -> str:
        """What its build system would still do right after the steps ran (a custom target
        that always runs): the package is then built every time; "" when nothing, or when the
        type cannot tell (BuildTypeBase: "")."""
        ...

    def keeps_earlier_work(self, ctx: PackageContext) -> bool:
        """Whether this build reuses what the last one left in the build directory (an
        incremental build): asked before the steps run (BuildTypeBase: False)."""
        ...

    def steps_run_afresh(self, ctx: PackageContext) -> frozenset[str]:
        """The labels of the steps that start from scratch in this build: what they read
        replaces what the last build's did (BuildTypeBase: none)."""
        ...

    def open_run(self, environ: Mapping[str, str]) -> None:
        """Once per run that builds one of its packages, before the first (BuildTypeBase:
        nothing to open)."""
        ...

    def close_run(self) -> None:
        """Once after the run's last package: stop what the run started for the type (the
        Python types' warm setup.py helpers). Safe to call when nothing was started."""
        ...


#: the options every build type reads that change how a build runs, never what it installs
_RUN_ONLY_OPTIONS = ("jobs", "compiler_launcher", "type_values")


def key_options(options: BuildOptions, declared: Sequence[TypeOption]) -> dict[str, object]:
    """The options that shape a package's output: the shared ones but those that only change
    how it runs, and the `declared` options of its type that count (`in_key`)."""
    shared = {k: v for k, v in asdict(options).items() if k not in _RUN_ONLY_OPTIONS}
    return {**shared, **{o.dest: options.value(o) for o in declared if o.in_key}}


class RunnerNamed:
    """A build type's test runner named by `module:attribute` and imported when first asked
    for, so that a build, which runs no test, imports no runner. The built-ins name theirs so:
    `test_runner = RunnerNamed("wsbuild.build_types.ctest:CTEST")`."""

    def __init__(self, target: str) -> None:
        self.target = target

    def __get__(self, instance: object, owner: type | None = None) -> TestRunner | None:
        if instance is None:  # asked of the class (the entry-point check): import nothing
            return self  # type: ignore[return-value]
        return load_value(self.target)  # type: ignore[return-value]


@dataclass(frozen=True, slots=True)
class BuildTypeBase:
    """Defaults for a build type: no tests, a plain prefix's hooks, CMake options ignored.
    Subclass it and override what differs (`name` and `steps` at least)."""

    name: str = ""
    hooks: EnvironmentHooks = EnvironmentHooks()
    estimate_base: float = 0.3
    #: its own options of `wsbuild build` (TypeOption): none
    options: tuple[TypeOption, ...] = ()
    #: the tool its build reads package.xml with when that tool refuses what wsbuild only
    #: warns about (workspace/model.py's `Package.refused`); "": none does
    manifest_reader: str = ""

    def run_facts(self, environ: Mapping[str, str]) -> object:
        """What the type needs to know once per run (the tools it runs): none."""
        return None

    def read_state(self, build_dir: Path) -> object:
        """What the type needs to know of a package's build directory: nothing."""
        return None

    @property
    def test_runner(self) -> TestRunner | None:
        """No tests; a subclass names its runner as a field, or with `RunnerNamed` (the
        built-ins: a build that runs no test imports no runner)."""
        return None

    def steps(self, ctx: PackageContext) -> list[Step]:
        raise NotImplementedError(f"build type '{self.name}' defines no steps")

    def key_options(self, options: BuildOptions) -> dict[str, object]:
        """The shared options that shape the output, and its own that do."""
        return key_options(options, self.options)

    def outside_reads(self, ctx: PackageContext) -> ReadOutside | list[str] | None:
        """What the steps reported reading outside the package (`ctx.outputs.read_outside`:
        the Python builds' setup.py, by an audit hook), else None."""
        return ctx.outputs.read_outside

    def work_left(self, ctx: PackageContext) -> str:
        return ""

    def keeps_earlier_work(self, ctx: PackageContext) -> bool:
        return False

    def steps_run_afresh(self, ctx: PackageContext) -> frozenset[str]:
        return frozenset()

    def open_run(self, environ: Mapping[str, str]) -> None:
        return None

    def close_run(self) -> None:
        return None


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
        loaded = load_value(value)
    else:
        matches = [ep for ep in _entry_points() if ep.name == name]
        if not matches:
            raise ManifestError(
                f"unknown build type '{name}'",
                hint="known build types: " + ", ".join(known_build_types()),
            )
        value = matches[0].value
        loaded = load_value(value)
    build_type = _checked(loaded, name, value)
    _loaded[name] = build_type
    return build_type


def type_options(name: str) -> tuple[TypeOption, ...]:
    """The options the build type `name` declares (its `options`); a built-in type's without
    importing it (BUILTIN_OPTIONS)."""
    if name in BUILTIN:
        value = BUILTIN_OPTIONS.get(name)
        return tuple(load_value(value)) if value else ()  # type: ignore[call-overload]
    return tuple(get_build_type(name).options)


def type_key_options(name: str, options: BuildOptions) -> dict[str, object]:
    """`get_build_type(name).key_options(options)`; a built-in type's from the options it
    declares, without importing it: a plan whose packages are all up to date imports no build
    type's steps (a test holds the two equal for each built-in type)."""
    if name in BUILTIN:
        return key_options(options, type_options(name))
    return get_build_type(name).key_options(options)


def declared_options(*, plugins: bool) -> list[tuple[str, tuple[TypeOption, ...]]]:
    """(build type, the options it declares) of each type that declares some: the built-in
    ones, and (`plugins`) those of every installed third-party type (which scanning the
    installed distributions costs). An option two types declare must be declared alike."""
    declared = [(name, type_options(name)) for name in BUILTIN_OPTIONS]
    if plugins:
        for entry in sorted(_entry_points(), key=lambda ep: ep.name):
            own = type_options(entry.name)
            if own:
                declared.append((entry.name, own))
    seen: dict[str, tuple[str, TypeOption]] = {}
    for name, options in declared:
        for option in options:
            for word in (option.flag, option.dest):
                if not word:
                    continue
                first = seen.setdefault(word, (name, option))
                if first[1] != option:
                    raise WsbuildError(
                        f"build type '{name}' declares the option {word} unlike build type "
                        f"'{first[0]}'",
                        hint="a build type names its own options (e.g. --<type>-args); "
                             "uninstall one of the two distributions")
    return declared


#: every member of the `BuildType` protocol (BuildTypeBase has them all)
#: everything wsbuild calls of a build type (the `BuildType` protocol, in its order)
_REQUIRED = ("name", "test_runner", "hooks", "estimate_base", "steps", "options", "key_options",
             "outside_reads", "run_facts", "read_state", "manifest_reader", "work_left",
             "keeps_earlier_work", "steps_run_afresh", "open_run", "close_run")


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


def _entry_points() -> Sequence[Entry]:
    """The third-party build types' entry points (build_types/plugins.py)."""
    return [entry for entry in entries(BUILD_TYPES) if entry.name not in BUILTIN]


class KnownBuildTypes(Collection[str]):
    """Built-in names answer at once; plugin entry points are scanned only for other names."""

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and is_known(name)

    def __iter__(self) -> Iterator[str]:
        return iter(known_build_types())

    def __len__(self) -> int:
        return len(list(iter(self)))
