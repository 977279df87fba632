"""colcon-metadata's per-package metadata: `colcon.meta` files (`--metas`, default
./colcon.meta) and $COLCON_HOME/metadata/*.meta (unless --ignore-user-meta), read strictly, and
the arguments they give each package: `cmake-args` and `ament-cmake-args` for its build,
`pytest-args` and `ctest-args` for its tests (each after the command line's, as colcon extends
a list option with a package's metadata). Other metadata keys are reported as ignored.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.errors import WsbuildError
from wsbuild import inputs
from wsbuild.verbs.mixin import config_home
from wsbuild.verbs.arguments import secondary

if TYPE_CHECKING:  # imported when a verb applies the metadata
    from wsbuild.builder.request import BuildRequest
    from wsbuild.testing.request import TestRequest
    from wsbuild.workspace.model import Package

META_FILE = "colcon.meta"
USER_DIR = "metadata"
#: the metadata keys `wsbuild build` applies per package: the list options the built-in build
#: types declare (build_types/cmake_options.py; a test holds the two equal), spelled as keys
BUILD_KEYS = ("cmake-args", "ament-cmake-args")
#: the metadata keys `wsbuild test` applies per package: a test tool's name → its key
TEST_KEYS = {"pytest": "pytest-args", "ctest": "ctest-args"}
#: every metadata key wsbuild applies (the others are ignored with a note)
APPLIED = (*BUILD_KEYS, *TEST_KEYS.values())


class MetadataError(WsbuildError):
    """A metadata file is unreadable or not colcon-metadata's format."""


@dataclass(slots=True)
class Metadata:
    """Per package name, the merged metadata of every file (colcon-metadata's merge rules)."""

    by_name: dict[str, dict[str, object]] = field(default_factory=dict)
    #: real path of a package directory → its metadata (a file's `paths:` section)
    by_path: dict[str, dict[str, object]] = field(default_factory=dict)

    def for_package(self, name: str, path: Path) -> dict[str, object]:
        merged: dict[str, object] = {}
        # (no file has a `paths:` section: where the directory really is cannot matter)
        by_path = self.by_path.get(inputs.realpath(path), {}) if self.by_path else {}
        for values in (by_path, self.by_name.get(name, {})):
            for key, value in values.items():
                _merge(merged, key, value)
        return merged


def _merge(target: dict[str, object], key: str, value: object) -> None:
    """colcon-metadata's rule: lists extend, mappings update, anything else replaces."""
    old = target.get(key)
    if isinstance(old, list) and isinstance(value, list):
        target[key] = [*old, *value]
    elif isinstance(old, dict) and isinstance(value, dict):
        target[key] = {**old, **value}
    else:
        target[key] = value


@dataclass(frozen=True, slots=True)
class MetadataRequest:
    """Which metadata files apply: `--metas` (None: ./colcon.meta if there) and the user's
    unless `--ignore-user-meta`."""

    metas: tuple[str, ...] | None = None
    ignore_user_meta: bool = False


def add_metadata_arguments(group: argparse._ActionsContainer) -> None:
    """colcon-metadata's options."""
    secondary(group.add_argument(
        "--metas", nargs="*", metavar="PATH",
        help="colcon.meta files, or directories holding them (default: ./colcon.meta)"))
    secondary(group.add_argument("--ignore-user-meta", action="store_true",
                                 help="not the metadata files under $COLCON_HOME/metadata"))


def metadata_from_args(args: argparse.Namespace) -> MetadataRequest:
    metas = getattr(args, "metas", None)
    return MetadataRequest(metas=None if metas is None else tuple(metas),
                           ignore_user_meta=bool(getattr(args, "ignore_user_meta", False)))


def metadata_files(request: MetadataRequest, environ: Mapping[str, str],
                   cwd: Path) -> list[Path]:
    """The metadata files that apply, in colcon-metadata's order: the user's, then --metas."""
    files: list[Path] = []
    if not request.ignore_user_meta:
        user = config_home(environ) / USER_DIR
        files += [Path(f) for f in inputs.walk_files(user) if f.endswith(".meta")]
    metas = request.metas
    for meta in metas if metas is not None else [META_FILE]:
        path = cwd / meta
        if inputs.is_dir(path):
            path = path / META_FILE
        if inputs.is_file(path):
            files.append(path)
        elif metas is not None and not inputs.is_dir(cwd / meta):
            raise MetadataError("--metas names a file that does not exist", path=path,
                                hint="a colcon.meta file, or a directory holding one")
    return files


def read_metadata(files: list[Path]) -> Metadata:
    """The `names:` and `paths:` sections of every file, merged in order."""
    result = Metadata()
    if not files:
        return result  # no YAML parser to load for most builds
    import yaml

    for path in files:
        try:
            data = yaml.safe_load(inputs.read_text(path))
        except (OSError, UnicodeDecodeError) as exc:
            raise MetadataError(f"cannot read the metadata file: {exc}", path=path) from None
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark
            raise MetadataError(f"invalid YAML: {exc.problem}", path=path,
                                line=mark.line + 1 if mark else None) from None
        if data is None:
            continue
        if not isinstance(data, dict):
            raise MetadataError("expected a mapping with 'names' and/or 'paths'", path=path,
                                hint='e.g. {"names": {"my_pkg": {"cmake-args": ["-DX=1"]}}}')
        for section in ("names", "paths"):
            entries = data.get(section) or {}
            if not isinstance(entries, dict) or not all(isinstance(v, dict)
                                                        for v in entries.values()):
                raise MetadataError(f"'{section}' must map each package to its metadata",
                                    path=path)
            for key, values in entries.items():
                if section == "names":
                    target = result.by_name.setdefault(str(key), {})
                else:
                    real = inputs.realpath(path.parent / str(key))
                    target = result.by_path.setdefault(real, {})
                for option, value in values.items():
                    _merge(target, str(option), value)
    return result


@dataclass(frozen=True, slots=True)
class PackageArguments:
    """What the metadata asks of the selected packages: per package, the arguments of each key
    the verb applies (`cmake-args` → ("-DX=1",)), and a note for each key no verb applies."""

    by_package: Mapping[str, Mapping[str, tuple[str, ...]]]
    notes: tuple[str, ...]


def package_arguments(metadata: Metadata, paths: Mapping[str, Path], selected: list[str],
                      keys: tuple[str, ...]) -> PackageArguments:
    """The metadata values of `keys` (those the verb applies) for each selected package;
    `paths`: package name → its directory. The keys another verb applies are left to it; any
    other key gets a note. Each item of a list is one argument, as colcon-metadata has it."""
    by_package: dict[str, dict[str, tuple[str, ...]]] = {}
    notes: list[str] = []
    for name in selected:
        for key, value in metadata.for_package(name, paths[name]).items():
            if key not in APPLIED:
                notes.append(f"colcon.meta: '{key}' of {name} is ignored: wsbuild applies "
                             f"{', '.join(APPLIED)} per package")
                continue
            items = value if isinstance(value, list) else [value]
            arguments = tuple(item for item in (str(v).strip() for v in items) if item)
            if key in keys and arguments:
                by_package.setdefault(name, {})[key] = arguments
    return PackageArguments(by_package, tuple(notes))


def with_build_arguments(request: BuildRequest, metadata: MetadataRequest,
                         packages: Mapping[str, Package],
                         selected: list[str]) -> tuple[BuildRequest, tuple[str, ...]]:
    """`request` with each selected package's own options (`cmake-args`, `ament-cmake-args`):
    its plan carries them, they reach its build only and enter its key only; and the notes of
    what is not applied."""
    from dataclasses import replace

    from wsbuild.builder.request import PackageOptions  # lazy: off `list` and `graph`

    found = read_metadata(metadata_files(metadata, os.environ, Path.cwd()))
    wanted = package_arguments(found, _paths(packages), selected, BUILD_KEYS)
    own = {name: PackageOptions(tuple(sorted((key.replace("-", "_"), arguments)
                                             for key, arguments in given.items())))
           for name, given in wanted.by_package.items()}
    return (replace(request, packages=own) if own else request), wanted.notes


def with_test_arguments(request: TestRequest, metadata: MetadataRequest,
                        packages: Mapping[str, Package],
                        selected: list[str]) -> tuple[TestRequest, tuple[str, ...]]:
    """`request` with each selected package's own test tool arguments (`pytest-args`,
    `ctest-args`, after the command line's, for that package only); and the notes."""
    from dataclasses import replace

    found = read_metadata(metadata_files(metadata, os.environ, Path.cwd()))
    wanted = package_arguments(found, _paths(packages), selected, tuple(TEST_KEYS.values()))
    own = {name: {tool: given[key] for tool, key in TEST_KEYS.items() if key in given}
           for name, given in wanted.by_package.items()}
    return (replace(request, package_arguments=own) if own else request), wanted.notes


def _paths(packages: Mapping[str, Package]) -> dict[str, Path]:
    return {name: package.path for name, package in packages.items()}
