"""The workspace data model: packages, dependencies and build results. No I/O here."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from pathlib import Path


class DepKind(Enum):
    """A package.xml dependency tag (after `depend`/`run_depend` have been expanded)."""

    BUILD = "build_depend"
    BUILDTOOL = "buildtool_depend"
    BUILD_EXPORT = "build_export_depend"
    BUILDTOOL_EXPORT = "buildtool_export_depend"
    EXEC = "exec_depend"
    TEST = "test_depend"
    DOC = "doc_depend"
    GROUP = "group_depend"


class DepCategory(Enum):
    """The three categories colcon orders by: build, run and test."""

    BUILD = "build"
    RUN = "run"
    TEST = "test"


#: How each tag maps to colcon's categories (doc_depend is kept but unused).
CATEGORY_KINDS: dict[DepCategory, frozenset[DepKind]] = {
    DepCategory.BUILD: frozenset({DepKind.BUILD, DepKind.BUILDTOOL, DepKind.GROUP}),
    DepCategory.RUN: frozenset(
        {DepKind.BUILD_EXPORT, DepKind.BUILDTOOL_EXPORT, DepKind.EXEC, DepKind.GROUP}
    ),
    DepCategory.TEST: frozenset({DepKind.TEST}),
}


@dataclass(frozen=True, slots=True)
class VersionConstraint:
    """One `version_*` attribute of a dependency, e.g. `version_gte="1.2"`."""

    op: str  # one of lt, lte, eq, gte, gt
    version: str


@dataclass(frozen=True, slots=True)
class Dependency:
    """One dependency tag whose condition (if any) evaluated true."""

    name: str
    kind: DepKind
    constraints: tuple[VersionConstraint, ...] = ()
    line: int | None = None


@dataclass(frozen=True, slots=True)
class Person:
    """A maintainer or author named in package.xml."""

    name: str
    email: str | None = None


@dataclass(frozen=True, slots=True)
class Package:
    """A package found in the workspace, with its manifest already evaluated."""

    name: str
    path: Path
    build_type: str
    version: str = "0.0.0"
    manifest: Path | None = None
    description: str = ""
    licenses: tuple[str, ...] = ()
    maintainers: tuple[Person, ...] = ()
    dependencies: tuple[Dependency, ...] = ()
    member_of_groups: tuple[str, ...] = ()
    #: extra `<export>` children other than build_type, as (tag, text) pairs
    exports: tuple[tuple[str, str], ...] = ()
    #: what wsbuild only warns about but catkin_pkg (ament's package.xml reader) refuses, as
    #: (line, problem, fix): an error for a build type whose build reads package.xml so
    refused: tuple[tuple[int, str, str], ...] = ()

    def dependency_names(self, category: DepCategory) -> frozenset[str]:
        """Names of the dependencies in one colcon category (groups not yet expanded)."""
        kinds = CATEGORY_KINDS[category]
        return frozenset(
            d.name for d in self.dependencies if d.kind in kinds and d.kind is not DepKind.GROUP
        )

    def group_names(self) -> frozenset[str]:
        return frozenset(d.name for d in self.dependencies if d.kind is DepKind.GROUP)


class Resolution(Enum):
    """Where a dependency was found: the source that resolved it (workspace/resolve.py)."""

    WORKSPACE = "workspace"
    AMENT_INDEX = "ament index"
    CMAKE = "cmake config"
    PYTHON = "python distribution"
    PYTHON_MODULE = "python module"
    EXECUTABLE = "executable"
    PKG_CONFIG = "pkg-config"
    SYSTEM = "system (not checked)"
    UNRESOLVED = "unresolved"


@dataclass(frozen=True, slots=True)
class ResolvedDependency:
    """A dependency, and where it was found (the workspace, an underlay, a module)."""

    name: str
    kinds: tuple[DepKind, ...]
    resolution: Resolution
    location: str = ""  # workspace path, underlay prefix or module file
