"""Build types: one module per `<build_type>` string, registered through one entry-point group.

A build type is a recipe: a short list of labelled steps (configure, build, install, ...).
Everything it touches (paths, environment, options, subprocesses) comes from the
`BuildContext`, so a unit test can hand in a recording fake.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from importlib.metadata import EntryPoint

from wsbuild.errors import ManifestError
from wsbuild.workspace.model import Package

ENTRY_POINT_GROUP = "wsbuild.build_types"

#: The built-in build types; their modules are imported only when a package needs them.
BUILTIN = ("ament_cmake", "ament_python", "cmake", "python")


@dataclass(frozen=True, slots=True)
class BuildOptions:
    """The options of `wsbuild build` that reach a package's build."""

    symlink_install: bool = False
    merge_install: bool = False
    cmake_args: tuple[str, ...] = ()
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


class Runner(Protocol):
    def __call__(self, command: Sequence[str], *, cwd: Path,
                 env: Mapping[str, str] | None = None) -> None: ...


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
    extra: dict[str, object] = field(default_factory=dict)

    @property
    def source_dir(self) -> Path:
        return self.package.path


@dataclass(frozen=True, slots=True)
class Step:
    label: str
    action: Callable[[BuildContext], None]


class BuildType(Protocol):
    """What a build type module exports as `BUILD_TYPE`."""

    name: str

    def steps(self, ctx: BuildContext) -> list[Step]:
        """The labelled steps that build and stage the package."""
        ...


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
        import importlib

        build_type: BuildType = importlib.import_module(f"wsbuild.build_types.{name}").BUILD_TYPE
    else:
        matches = [ep for ep in _entry_points() if ep.name == name]
        if not matches:
            raise ManifestError(
                f"unknown build type '{name}'",
                hint="known build types: " + ", ".join(known_build_types()),
            )
        build_type = matches[0].load()
    _loaded[name] = build_type
    return build_type


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
