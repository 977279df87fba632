"""Resolve the dependencies that are not workspace packages, and say which source provides each.

A dependency is resolved by the first of these that has it:

1. a workspace package;
2. the ament index of a prefix on `AMENT_PREFIX_PATH` (or the venv underlay);
3. a CMake package config (`<name>Config.cmake` / `<name>-config.cmake`) in `CMAKE_PREFIX_PATH`;
4. a Python distribution installed for the build interpreter (names compared normalised;
   rosdep's `python3-` prefix dropped: `python3-numpy` → `numpy`, `xacro` → `xacro`);
5. an executable on `PATH`;
6. a `pkg-config` module;
7. for `python3-*` keys, an importable module of that name (`python3-yaml` → `yaml`).

Names that are rosdep keys of system packages (a `-` in the name, which REP 144 forbids for
ROS packages, or a well-known key) and that none of the above finds are "system (not
checked)"; everything else is unresolved. The build only warns about unresolved ones
(builder/pipeline.py): a dependency declared for the run time or for another platform must not
stop a build that would succeed.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import re
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.workspace.model import DepKind, Package, Resolution, ResolvedDependency
from wsbuild import inputs
from wsbuild.signature import stat_signature
from wsbuild.files import atomic_write, private_directory
from wsbuild.patterns import lazy

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
    "python3-rosdistro-modules": "rosdistro",
    "python3-rospkg-modules": "rospkg",
}
#: rosdep keys whose PyPI distribution is not the key minus "python3-"
_PYTHON_DISTRIBUTIONS = {
    "python3-yaml": "pyyaml",
    "python3-opencv": "opencv-python",
    "python3-pil": "pillow",
    "python3-serial": "pyserial",
    "python3-dateutil": "python-dateutil",
    "python3-catkin-pkg-modules": "catkin-pkg",
    "python3-lark-parser": "lark",
    "python3-pkg-resources": "setuptools",
    "python3-rosdistro-modules": "rosdistro",
    "python3-rospkg-modules": "rospkg",
    "python3-rosdep": "rosdep",
}
#: common rosdep keys for system libraries and tools that carry no ament index entry
SYSTEM_KEYS = frozenset({
    "boost", "bullet", "cmake", "curl", "eigen", "git", "gtest", "gmock", "libcurl",
    "libyaml", "opencv", "openssl", "pkg-config", "python3", "python3-dev", "qtbase5-dev",
    "tinyxml", "tinyxml2", "uncrustify", "cppcheck", "zlib", "assimp", "libpcl-all-dev",
    "pybind11-dev", "libboost-dev", "yaml-cpp", "yaml_cpp", "spdlog", "fmt", "sqlite3",
    "libsqlite3-dev", "lttng-ust", "liblttng-ust-dev", "acl", "libacl1-dev",
})
#: what a pkg-config module name may look like (it is passed as one argument, never to a shell)
_PKG_CONFIG_NAME = lazy(r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$")


def python_distribution(key: str) -> str | None:
    """The PyPI distribution of a `python3-*` rosdep key by convention (`python3-psutil` →
    `psutil`, `python3-yaml` → `pyyaml`), or None for other keys."""
    if not key.startswith("python3-") or key == "python3-dev":
        return None
    return _PYTHON_DISTRIBUTIONS.get(key, key[len("python3-"):])


def normalize_distribution(name: str) -> str:
    """A Python distribution name as PEP 503 compares it."""
    return re.sub(r"[-_.]+", "-", name).lower()


@dataclass(slots=True)
class Resolver:
    """Looks dependency names up in the underlays once, then answers from memory."""

    ament_prefixes: Sequence[Path]
    cmake_prefixes: Sequence[Path]
    #: PATH of the build, for executables and pkg-config
    path: str = ""
    #: PKG_CONFIG_PATH of the build
    pkg_config_path: str = ""
    #: where the build interpreter's distributions live (site-packages and PYTHONPATH entries)
    python_paths: Sequence[str] = ()
    #: name each source's answer as its metadata spells it, with its version (`wsbuild info`);
    #: otherwise answers come from directory listings and one pkg-config run (the build's check)
    detailed: bool = False
    #: a file remembering pkg-config's compiled-in search path by the program's signature (a
    #: no-op build then starts no process); None: ask the program
    memo: Path | None = None
    #: whether a new answer is written to `memo` (not by a dry run)
    remember: bool = True
    _ament_index: dict[str, Path] | None = field(default=None, repr=False)
    _distributions: dict[str, str] | None = field(default=None, repr=False)
    _pkg_config_modules: frozenset[str] | None = field(default=None, repr=False)
    _pkg_config_dirs: list[str] | None = field(default=None, repr=False)
    _cache: dict[str, tuple[Resolution, str]] = field(default_factory=dict, repr=False)

    @classmethod
    def from_environment(cls, environ: Mapping[str, str],
                         extra_prefixes: Iterable[Path] = (), *, detailed: bool = False,
                         memo: Path | None = None, remember: bool = True) -> Resolver:
        """The build's view: its environment, plus `extra_prefixes` (the venv underlay)."""
        extra = list(extra_prefixes)
        python_paths = _split_str(environ.get("PYTHONPATH", ""))
        for prefix in extra:
            python_paths += [os.path.join(d, "site-packages")
                             for d in inputs.glob_dirs(prefix / "lib", "python3*")
                             if inputs.is_dir(os.path.join(d, "site-packages"))]
        python_paths += [p for p in sys.path if p]
        return cls(
            ament_prefixes=_split(environ.get("AMENT_PREFIX_PATH", "")) + extra,
            cmake_prefixes=_split(environ.get("CMAKE_PREFIX_PATH", "")) + extra,
            path=environ.get("PATH", ""),
            pkg_config_path=environ.get("PKG_CONFIG_PATH", ""),
            python_paths=tuple(dict.fromkeys(python_paths)),
            detailed=detailed,
            memo=memo,
            remember=remember,
        )

    def resolve(self, name: str) -> tuple[Resolution, str]:
        """Where an external dependency comes from (not consulting the workspace)."""
        if name not in self._cache:
            self._cache[name] = self._lookup(name)
        return self._cache[name]

    def _lookup(self, name: str) -> tuple[Resolution, str]:
        index = self._index()
        if name in index:
            return Resolution.AMENT_INDEX, str(index[name])
        config = self._cmake_config(name)
        if config is not None:
            return Resolution.CMAKE, str(config)
        distribution = self._distribution(name)
        if distribution is not None:
            return Resolution.PYTHON, distribution
        executable = inputs.which(name, path=self.path) if self.path else None
        if executable is not None:
            return Resolution.EXECUTABLE, executable
        module = self._pkg_config(name)
        if module is not None:
            return Resolution.PKG_CONFIG, module
        if name.startswith("python3-"):
            module_name = _PYTHON_MODULES.get(name, name[len("python3-"):].replace("-", "_"))
            for directory in sys.path:  # where the import system looks
                if directory:
                    inputs.declare_directory(os.path.abspath(directory))
            try:
                spec = importlib.util.find_spec(module_name)
            except (ImportError, ValueError):
                spec = None
            if spec is not None:
                return Resolution.PYTHON_MODULE, str(spec.origin or module_name)
            return Resolution.UNRESOLVED, f"no Python distribution or module '{module_name}'"
        if name in SYSTEM_KEYS or "-" in name:
            # REP 144 names have no '-': this is a rosdep key for a system package
            return Resolution.SYSTEM, ""
        return Resolution.UNRESOLVED, ""

    def _index(self) -> dict[str, Path]:
        if self._ament_index is None:
            self._ament_index = ament_index(self.ament_prefixes)
        return self._ament_index

    def _cmake_config(self, name: str) -> Path | None:
        for prefix in self.cmake_prefixes:
            for folder in (
                prefix / "share" / name / "cmake",
                prefix / "share" / name,
                prefix / "lib" / "cmake" / name,
                prefix / "lib" / name / "cmake",
                prefix / "lib" / "cmake" / name.lower(),
            ):
                for config in (f"{name}Config.cmake", f"{name.lower()}-config.cmake"):
                    if inputs.is_file(folder / config):
                        return folder / config
        return None

    def _distribution(self, name: str) -> str | None:
        if self._distributions is None:
            self._distributions = python_distributions(self.python_paths,
                                                       read_metadata=self.detailed)
        candidates = [name]
        if name.startswith("python3-"):
            candidates = [python_distribution(name) or name]
        for candidate in candidates:
            found = self._distributions.get(normalize_distribution(candidate))
            if found is not None:
                return found
        return None

    def _pkg_config(self, name: str) -> str | None:
        if not _PKG_CONFIG_NAME.match(name):
            return None
        if self._pkg_config_modules is None:
            self._pkg_config_modules = self._list_pkg_config_modules()
        if name not in self._pkg_config_modules:
            return None
        return self._pkg_config_version(name) if self.detailed else name

    def _pkg_config_version(self, name: str) -> str:
        import subprocess

        tool = inputs.which("pkg-config", path=self.path) or "pkg-config"
        env = dict(os.environ, PATH=self.path, PKG_CONFIG_PATH=self.pkg_config_path)
        try:
            done = subprocess.run([tool, "--modversion", name], env=env, capture_output=True,
                                  text=True, timeout=10, check=False)
        except (OSError, subprocess.TimeoutExpired):
            return name
        return f"{name} {done.stdout.strip()}".strip() if done.returncode == 0 else name

    def pkg_config_search_path(self) -> list[str]:
        """The directories pkg-config searches: PKG_CONFIG_PATH, then PKG_CONFIG_LIBDIR when
        set, else its compiled-in default (remembered by the program's signature) — each
        declared as an input of the run (wsbuild/inputs.py): a module installed into one
        changes its listing. Worked out once per resolver."""
        if self._pkg_config_dirs is not None:
            return self._pkg_config_dirs
        tool = inputs.which("pkg-config", path=self.path) if self.path else None
        if tool is not None:
            inputs.declare_file(tool)
        directories = _split_str(self.pkg_config_path)
        libdir = os.environ.get("PKG_CONFIG_LIBDIR")
        if libdir is not None:
            directories += _split_str(libdir)
        elif tool is not None:
            directories += _split_str(_pkg_config_default_path(inputs.realpath(tool), self.memo,
                                                                  write=self.remember))
        self._pkg_config_dirs = list(dict.fromkeys(directories))
        for directory in self._pkg_config_dirs:
            inputs.declare_directory(directory)
        return self._pkg_config_dirs

    def _list_pkg_config_modules(self) -> frozenset[str]:
        """Every module pkg-config knows, from one run (not one per dependency)."""
        tool = inputs.which("pkg-config", path=self.path) if self.path else None
        self.pkg_config_search_path()
        if tool is None:
            return frozenset()
        import subprocess

        env = dict(os.environ, PATH=self.path, PKG_CONFIG_PATH=self.pkg_config_path)
        try:
            done = subprocess.run([tool, "--list-all"], env=env, capture_output=True,
                                  text=True, timeout=30, check=False)
        except (OSError, subprocess.TimeoutExpired):
            return frozenset()
        return frozenset(line.split(None, 1)[0] for line in done.stdout.splitlines()
                         if line.strip())

    def fingerprint(self) -> dict[str, object]:
        """What the answers depend on, cheaply: the search paths, and the modification times
        of the directories a wheel, package or library is installed into or removed from.
        Equal fingerprints mean equal answers (builder/unresolved.py remembers them)."""
        directories: list[str] = []
        for prefix in self.ament_prefixes:
            directories.append(str(prefix / "share" / "ament_index" / "resource_index"
                                   / "packages"))
        for prefix in self.cmake_prefixes:
            directories += [str(prefix / "share"), str(prefix / "lib" / "cmake"),
                            str(prefix / "lib")]
        directories += list(self.python_paths)
        directories += _split_str(self.path) + self.pkg_config_search_path()
        return {
            "ament_prefixes": [str(p) for p in self.ament_prefixes],
            "cmake_prefixes": [str(p) for p in self.cmake_prefixes],
            "path": self.path,
            "pkg_config_path": self.pkg_config_path,
            "python_paths": list(self.python_paths),
            "mtimes": [_mtime(d) for d in dict.fromkeys(directories)],
        }


def _pkg_config_default_path(tool: str, memo: Path | None, *, write: bool = True) -> str:
    """pkg-config's compiled-in search path (`pc_path`) of the program at `tool` (its real
    path): from `memo` while the program's signature is the one remembered, else asked."""
    import json

    signature: list[object] = list(inputs.signature(tool))
    if signature == list(inputs.ABSENT):
        return ""
    known: dict[str, object] = {}
    if memo is not None:
        try:
            loaded = json.loads(inputs.read_text(memo))
            known = loaded if isinstance(loaded, dict) else {}
        except (OSError, ValueError):
            known = {}
        entry = known.get(tool)
        if isinstance(entry, list) and entry[:-1] == signature and isinstance(entry[-1], str):
            return entry[-1]
    found = _ask_pkg_config_default_path(tool)
    if memo is not None and write:
        try:
            private_directory(memo.parent)
            atomic_write(memo, json.dumps({**known, tool: [*signature, found]}, sort_keys=True))
        except OSError:
            pass  # asked again next time
    return found


@functools.lru_cache(maxsize=4)
def _ask_pkg_config_default_path(tool: str) -> str:
    import subprocess

    try:
        done = subprocess.run([tool, "--variable", "pc_path", "pkg-config"],
                              capture_output=True, text=True, timeout=10, check=False,
                              env={k: v for k, v in os.environ.items()
                                   if not k.startswith("PKG_CONFIG")})
    except (OSError, subprocess.TimeoutExpired):
        return ""
    return done.stdout.strip() if done.returncode == 0 else ""


def _mtime(directory: str) -> list[int]:
    """A directory's stat signature (0s when it does not exist)."""
    try:
        st = inputs.stat(directory)
    except OSError:
        return [0, 0, 0, 0, 0]
    return list(stat_signature(st))


def python_distributions(paths: Iterable[str], *, read_metadata: bool = False
                         ) -> dict[str, str]:
    """Normalised name -> "name version" of every distribution installed in `paths`, read from
    the `*.dist-info` / `*.egg-info` directory names (no metadata is parsed: a ROS venv holds
    hundreds of distributions), or with `read_metadata` as their metadata names them."""
    if read_metadata:
        return _distributions_from_metadata(paths)
    found: dict[str, str] = {}
    for path in paths:
        try:
            entries = sorted(inputs.listdir(path))
        except OSError:
            continue
        for entry in entries:
            stem, dot, suffix = entry.rpartition(".")
            if not dot or suffix not in ("dist-info", "egg-info"):
                continue
            name, _, version = stem.partition("-")
            if name:
                found.setdefault(normalize_distribution(name), f"{name} {version}".strip())
    return found


def _distributions_from_metadata(paths: Iterable[str]) -> dict[str, str]:
    import importlib.metadata

    found: dict[str, str] = {}
    for path in paths:  # each distribution's metadata directory is an entry there
        inputs.declare_directory(path)
    for dist in importlib.metadata.distributions(path=list(paths)):
        try:
            name = dist.metadata["Name"]
        except (KeyError, OSError):
            continue
        finally:  # what importlib.metadata looked at and read of it
            location = getattr(dist, "_path", None)
            if location is not None:
                for file_name in ("METADATA", "PKG-INFO"):
                    inputs.declare_file(os.path.join(location, file_name))
        if name:
            found.setdefault(normalize_distribution(name), f"{name} {dist.version}")
    return found


def ament_index(prefixes: Iterable[Path]) -> dict[str, Path]:
    """package -> the first prefix whose ament resource index lists it (as ament_index does)."""
    index: dict[str, Path] = {}
    for prefix in prefixes:
        try:
            names = inputs.listdir(prefix / "share" / "ament_index" / "resource_index" / "packages")
        except OSError:
            continue
        for name in names:
            index.setdefault(name, prefix)
    return index


def _split(value: str) -> list[Path]:
    return [Path(p) for p in value.split(os.pathsep) if p]


def _split_str(value: str) -> list[str]:
    return [p for p in value.split(os.pathsep) if p]


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


#: the kinds a build needs (colcon's build category); run-time and test ones are not checked
BUILD_KINDS = frozenset({DepKind.BUILD, DepKind.BUILDTOOL})


def unresolved_build_dependencies(
    packages: Iterable[Package], workspace: Mapping[str, Package], resolver: Resolver
) -> dict[str, list[ResolvedDependency]]:
    """package -> its build/buildtool dependencies that no source provides (packages with
    none left out), in the order of `packages`."""
    missing: dict[str, list[ResolvedDependency]] = {}
    for package in packages:
        unresolved = [
            dep for dep in resolve_dependencies(package, workspace, resolver)
            if BUILD_KINDS.intersection(dep.kinds) and dep.resolution is Resolution.UNRESOLVED
        ]
        if unresolved:
            missing[package.name] = unresolved
    return missing
