"""Classify dependencies that are not workspace packages: underlay, Python module, system, or missing."""

from __future__ import annotations

import importlib.util
import os
import shutil
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.workspace.model import DepKind, Package, Resolution, ResolvedDependency

#: rosdep keys whose Python module name is not the key minus "python3-"
_PYTHON_MODULES = {
    "python3-yaml": "yaml",
    "python3-empy": "em",
    "python3-opencv": "cv2",
    "python3-pil": "PIL",
    "python3-pytest": "pytest",
    "python3-pytest-cov": "pytest_cov",
    "python3-serial": "serial",
    "python3-dateutil": "dateutil",
    "python3-catkin-pkg": "catkin_pkg",
    "python3-catkin-pkg-modules": "catkin_pkg",
    "python3-rosdep": "rosdep2",
    "python3-lark-parser": "lark",
    "python3-importlib-metadata": "importlib_metadata",
    "python3-pkg-resources": "pkg_resources",
    "python3-scipy": "scipy",
    "python3-matplotlib": "matplotlib",
    "python3-psutil": "psutil",
    "python3-requests": "requests",
    "python3-setuptools": "setuptools",
    "python3-transforms3d": "transforms3d",
}
#: common rosdep keys for system libraries and tools that carry no ament index entry
SYSTEM_KEYS = frozenset({
    "boost", "bullet", "cmake", "curl", "eigen", "git", "gtest", "gmock", "libcurl",
    "libyaml", "opencv", "openssl", "pkg-config", "python3", "python3-dev", "qtbase5-dev",
    "tinyxml", "tinyxml2", "uncrustify", "cppcheck", "zlib", "assimp", "libpcl-all-dev",
    "pybind11-dev", "libboost-dev", "yaml-cpp", "yaml_cpp", "spdlog", "fmt", "sqlite3",
    "libsqlite3-dev", "lttng-ust", "liblttng-ust-dev", "acl", "libacl1-dev",
})


@dataclass(slots=True)
class Resolver:
    """Looks dependency names up in the underlays once, then answers from memory."""

    ament_prefixes: Sequence[Path]
    cmake_prefixes: Sequence[Path]
    _ament_index: dict[str, Path] | None = field(default=None, repr=False)
    _cache: dict[str, tuple[Resolution, str]] = field(default_factory=dict, repr=False)

    @classmethod
    def from_environment(cls, environ: Mapping[str, str],
                         extra_prefixes: Iterable[Path] = ()) -> Resolver:
        extra = list(extra_prefixes)
        return cls(
            ament_prefixes=_split(environ.get("AMENT_PREFIX_PATH", "")) + extra,
            cmake_prefixes=_split(environ.get("CMAKE_PREFIX_PATH", "")) + extra,
        )

    def resolve(self, name: str) -> tuple[Resolution, str]:
        """Where an external dependency comes from (not consulting the workspace)."""
        if name not in self._cache:
            self._cache[name] = self._lookup(name)
        return self._cache[name]

    def _lookup(self, name: str) -> tuple[Resolution, str]:
        index = self._index()
        if name in index:
            return Resolution.UNDERLAY, str(index[name])
        for prefix in self.cmake_prefixes:
            for candidate in (
                prefix / "share" / name / "cmake",
                prefix / "lib" / "cmake" / name,
                prefix / "share" / name / "package.xml",
            ):
                if candidate.exists():
                    return Resolution.UNDERLAY, str(prefix)
        if name.startswith("python3-"):
            module = _PYTHON_MODULES.get(name, name[len("python3-"):].replace("-", "_"))
            try:
                spec = importlib.util.find_spec(module)
            except (ImportError, ValueError):
                spec = None
            if spec is not None:
                return Resolution.PYTHON, str(spec.origin or module)
            return Resolution.UNRESOLVED, f"no importable module '{module}'"
        tool = shutil.which(name) if name in SYSTEM_KEYS else None
        if tool is not None:
            return Resolution.SYSTEM, tool  # a build tool found on PATH: checked
        if name in SYSTEM_KEYS or "-" in name:
            # REP 144 names have no '-': this is a rosdep key for a system package
            return Resolution.SYSTEM, ""
        return Resolution.UNRESOLVED, ""

    def _index(self) -> dict[str, Path]:
        if self._ament_index is None:
            self._ament_index = ament_index(self.ament_prefixes)
        return self._ament_index


def ament_index(prefixes: Iterable[Path]) -> dict[str, Path]:
    """package -> the first prefix whose ament resource index lists it (as ament_index does)."""
    index: dict[str, Path] = {}
    for prefix in prefixes:
        try:
            names = os.listdir(prefix / "share" / "ament_index" / "resource_index" / "packages")
        except OSError:
            continue
        for name in names:
            index.setdefault(name, prefix)
    return index


def _split(value: str) -> list[Path]:
    return [Path(p) for p in value.split(os.pathsep) if p]


def resolve_dependencies(
    package: Package, workspace: Mapping[str, Package], resolver: Resolver
) -> list[ResolvedDependency]:
    """Every dependency of `package` (grouped by name, kinds merged) with where it resolves."""
    kinds: dict[str, list[DepKind]] = {}
    for dep in package.dependencies:
        kinds.setdefault(dep.name, [])
        if dep.kind not in kinds[dep.name]:
            kinds[dep.name].append(dep.kind)
    result = []
    for name in sorted(kinds):
        if name in workspace:
            resolution, location = Resolution.WORKSPACE, str(workspace[name].path)
        elif package.manifest is None:
            # plain CMake packages: find_package() names outside the workspace are system ones
            resolution, location = resolver.resolve(name)
            if resolution is Resolution.UNRESOLVED:
                resolution = Resolution.SYSTEM
        else:
            resolution, location = resolver.resolve(name)
        result.append(ResolvedDependency(name, tuple(kinds[name]), resolution, location))
    return result


BUILD_KINDS = frozenset({DepKind.BUILD, DepKind.BUILDTOOL})


def unresolved_build_dependencies(
    packages: Iterable[Package], workspace: Mapping[str, Package], resolver: Resolver
) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
    """(missing, unchecked): dependency name -> packages needing it, for build/buildtool deps."""
    missing: dict[str, list[str]] = {}
    unchecked: dict[str, list[str]] = {}
    for package in packages:
        for dep in resolve_dependencies(package, workspace, resolver):
            if not BUILD_KINDS.intersection(dep.kinds):
                continue
            if dep.resolution is Resolution.UNRESOLVED:
                missing.setdefault(dep.name, []).append(package.name)
            elif (dep.resolution is Resolution.SYSTEM and package.manifest is not None
                  and not dep.location):
                unchecked.setdefault(dep.name, []).append(package.name)
    return missing, unchecked
