"""ROS CMake packages that the underlay's CMake files `find_package()` but that no wheel
installed: the ros-jazzy-* wheels' metadata forgets several."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from wsbuild.underlay.detect import RESOURCE_INDEX, ros_distro
from wsbuild.underlay.repair import cmake_files
from wsbuild.patterns import lazy

#: Wheels the ros-jazzy-* metadata forgets: `find_package()` fails without them (the first
#: three for any ament_cmake / rosidl package, the gtest/gmock/pytest ones once
#: ament_cmake_ros is there, the vendors for `ament_add_gtest`/`ament_add_gmock`).
#: `missing_packages` finds them one level at a time; this is the whole list for Jazzy.
EXTRA_REQUIREMENTS = (
    "ros-jazzy-ament-package",
    "ros-jazzy-ament-cmake-include-directories",
    "ros-jazzy-ament-cmake-ros",
    "ros-jazzy-rosidl-core-generators",
    "ros-jazzy-ament-cmake-gtest",
    "ros-jazzy-ament-cmake-gmock",
    "ros-jazzy-ament-cmake-pytest",
    "ros-jazzy-gtest-vendor",
    "ros-jazzy-gmock-vendor",
)
_FIND_PACKAGE = lazy(r"find_package\(\s*([A-Za-z0-9_]+)([^)]*)\)")
_EXPORTED_DEPENDENCIES = lazy(r'set\(_exported_dependencies\s+"([^"]*)"\)')


@dataclass(frozen=True)
class MissingPackage:
    """A CMake package that installed underlay files `find_package()` but nobody installed."""

    name: str
    required_by: tuple[str, ...]
    requirement: str


def _resolvable(prefix: Path, name: str) -> bool:
    share = prefix / "share" / name
    for folder in (share / "cmake", share, prefix / "lib" / "cmake" / name, prefix / "lib" / name / "cmake"):
        if (folder / f"{name}Config.cmake").is_file() or (folder / f"{name}-config.cmake").is_file():
            return True
    return (prefix / RESOURCE_INDEX / "packages" / name).is_file()


def missing_packages(prefix: Path) -> list[MissingPackage]:
    """ROS CMake packages that installed CMake files `find_package()` (not QUIET, or listed
    in an `ament_export_dependencies` extras file) but that are not installed: the wheels' metadata forgets several (`ament_cmake_include_directories`,
    `ament_cmake_ros`, `rosidl_core_generators`, `ament_cmake_gtest` ...).

    Only lower-case names are considered (ROS package names); system packages such as
    `Python3` or `OpenSSL` are CMake's business.  `requirement` is the PyPI name.
    """
    prefix = Path(os.path.abspath(prefix))
    distro = ros_distro(prefix) or "jazzy"
    wanted: dict[str, set[str]] = {}
    find_modules: set[str] = set()  # Find<name>.cmake shipped by *_cmake_module / vendor packages
    for path in cmake_files(prefix):
        if path.name.startswith("Find"):
            find_modules.add(path.name[4:-6])
        try:
            text = path.read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        if "find_package" not in text:
            continue
        rel = path.relative_to(prefix).parts
        owner = rel[2] if rel[:2] == ("lib", "cmake") else rel[1]
        names: list[str] = []
        for raw in text.splitlines():
            line = raw.split("#", 1)[0]
            for match in _FIND_PACKAGE.finditer(line):
                name, args = match.group(1), match.group(2).split()
                if "QUIET" not in args or "REQUIRED" in args:
                    names.append(name)
            # ament_export_dependencies(): find_package("${_dep}" QUIET REQUIRED) in a loop
            for match in _EXPORTED_DEPENDENCIES.finditer(line):
                names.extend(n for n in match.group(1).split(";") if n)
        for name in names:
            if name == name.lower():
                wanted.setdefault(name, set()).add(owner)
    result = []
    for name in sorted(wanted):
        if name not in find_modules and not _resolvable(prefix, name):
            result.append(
                MissingPackage(
                    name=name,
                    required_by=tuple(sorted(wanted[name])),
                    requirement=f"ros-{distro}-{name.replace('_', '-')}",
                )
            )
    return result
