"""What a `wsbuild build` (or `wsbuild test`) run was asked to do: validated, frozen records.

`verbs/build.py` makes these of the command line and colcon.meta; the build room reads them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

from wsbuild.build_types import BuildOptions
from wsbuild.cache.settings import CacheSettings
from wsbuild.engine.memory_budget import MemoryLimit
from wsbuild.engine.timings import cpu_count

if TYPE_CHECKING:
    from wsbuild.builder.shards.split import Assembly
    from wsbuild.builder.shards.split import ShardSpec

#: cpu_count is the engine's (the test run counts the cores too); the verbs find it here
__all__ = ["BuildRequest", "RunOptions", "cpu_count", "options_of_record"]


@dataclass(frozen=True, slots=True)
class RunOptions:
    """How packages are scheduled and reported (shared by build and test)."""

    workers: int
    continue_on_error: bool
    wait_for_lock: bool


@dataclass(frozen=True, slots=True)
class PackageOptions:
    """What one package's build gets beyond the run's options (colcon.meta's `cmake-args`,
    `ament-cmake-args`, … for it): the values of list options of the build types (by dest),
    which extend the run's lists, as colcon extends a list option with a package's metadata
    values."""

    arguments: tuple[tuple[str, tuple[str, ...]], ...] = ()

    def applied_to(self, options: BuildOptions) -> BuildOptions:
        """The run's `options` with this package's own added after them."""
        if not self.arguments:
            return options
        run = dict(options.type_values)
        return options.with_values({dest: (*run.get(dest, ()), *arguments)  # type: ignore[misc]
                                    for dest, arguments in self.arguments})


@dataclass(frozen=True, slots=True)
class BuildRequest:
    """What the command line (with defaults files and mixins) asks of a build."""

    build: BuildOptions
    run: RunOptions
    #: package name → what its build gets beyond `build` (a package not named: nothing)
    packages: Mapping[str, PackageOptions] = field(default_factory=dict)
    skip_dependency_check: bool = False
    #: --strict-dependencies: unresolved build dependencies refuse the build (exit 2)
    strict_dependencies: bool = False
    force: bool = False
    repair_underlay: bool = True
    #: --compiler-cache: auto, sccache, ccache or none (builder/resources/compiler_cache.py)
    compiler_cache: str = "auto"
    #: --timings: print per-package phase times and CPU time against the limit
    timings: bool = False
    #: the build cache; None: off (what --no-cache and WSBUILD_CACHE=off ask for)
    cache: CacheSettings | None = None
    #: --allow-overriding: packages built although an underlay provides them to others
    allow_overriding: tuple[str, ...] = ()
    #: log/<run>/report.json and report.html (--no-report: off)
    report: bool = True
    #: --distribute: distcc hosts in DISTCC_HOSTS syntax; None: compile here only
    #: (builder/resources/distcc.py)
    distribute: str | None = None
    #: --env-ignore: variables that reach no build, beside record/environment.py's own list
    env_ignore: tuple[str, ...] = ()
    #: --shard K/N: this job's share of a build split across a CI matrix (builder/shards/split.py)
    shard: ShardSpec | None = None
    #: --assemble N: the job after a matrix of N shards (builder/shards/cover.py)
    assemble: Assembly | None = None
    #: --memory-limit / --no-memory-limit: the memory budget (builder/resources/memory.py)
    memory: MemoryLimit = MemoryLimit()


def options_of_record(options: Mapping[str, object]) -> BuildOptions:
    """The build options a package's record holds (its settings' `options`: what shaped its
    output), as the options of a build that makes the same output again."""
    from dataclasses import fields

    shared = {f.name for f in fields(BuildOptions)}
    values = {name: tuple(value) if isinstance(value, list) else value
              for name, value in options.items()}
    return replace(BuildOptions(**{k: v for k, v in values.items() if k in shared}),
                   jobs=cpu_count()).with_values(  # type: ignore[arg-type]
        {k: v for k, v in values.items() if k not in shared})
