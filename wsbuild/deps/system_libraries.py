"""The system libraries ROS wheels link but do not bring: building against such a wheel needs
the library's development package (the tracetools wheel exports `-llttng-ust`, which nothing
declares; rclcpp, built from source on a pip-only machine, links it through tracetools)."""

from __future__ import annotations

import glob
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from wsbuild.deps.needs import Need
from wsbuild.deps.plan import Installer, Source, Step
from wsbuild.workspace.model import DepKind, Package, Resolution


@dataclass(frozen=True, slots=True)
class SystemLibrary:
    """A library a wheel's CMake config links by name, and the Debian package with it."""

    library: str
    apt: str


#: ROS package (a wheel) → the system libraries its exported targets link
WHEEL_SYSTEM_LIBRARIES: dict[str, tuple[SystemLibrary, ...]] = {
    "tracetools": (SystemLibrary("lttng-ust", "liblttng-ust-dev"),),
}
#: where a library to link (`lib<name>.so`) is looked for
LIBRARY_DIRECTORIES = ("/usr/lib", "/usr/lib/*-linux-gnu", "/lib/*-linux-gnu", "/usr/local/lib")
#: the kinds of dependency a build links against
_BUILD_KINDS = frozenset({DepKind.BUILD, DepKind.BUILD_EXPORT})


def installed_library(name: str, directories: Sequence[str] = LIBRARY_DIRECTORIES) -> bool:
    """Whether `lib<name>.so` (what `-l<name>` links) is in one of `directories`."""
    return any(glob.glob(f"{directory}/lib{name}.so") for directory in directories)


def system_library_steps(packages: Iterable[Package], kinds: frozenset[DepKind], *,
                         directories: Sequence[str] = LIBRARY_DIRECTORIES) -> list[Step]:
    """An apt step for each system library a wheel the packages build against links and that
    is not installed."""
    if not kinds & _BUILD_KINDS:
        return []
    users: dict[SystemLibrary, list[str]] = {}
    for package in packages:
        for dependency in package.dependencies:
            if dependency.kind not in _BUILD_KINDS:
                continue
            for library in WHEEL_SYSTEM_LIBRARIES.get(dependency.name, ()):
                if not installed_library(library.library, directories):
                    users.setdefault(library, [])
                    if package.name not in users[library]:
                        users[library].append(package.name)
    return [Step(Need(library.apt, tuple(names), (DepKind.BUILD,), Resolution.UNRESOLVED,
                      location=f"lib{library.library}.so"),
                 Source.SYSTEM_LIBRARY, Installer.APT, (library.apt,))
            for library, names in sorted(users.items(), key=lambda item: item[0].apt)]
