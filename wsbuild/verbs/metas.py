"""colcon-metadata's per-package metadata: `colcon.meta` files (`--metas`, default
./colcon.meta) and $COLCON_HOME/metadata/*.meta (unless --ignore-user-meta), read strictly, and
their per-package CMake arguments handed to each package's configure.

wsbuild's build takes one set of `--cmake-args` for the whole run, so a package's own `-D`
arguments reach its CMake through one initial-cache script (`cmake -C`) that sets them only
when CMake configures that package's build directory. Other metadata keys, and arguments that
are not `-D`, are reported as ignored.
"""

from __future__ import annotations

import argparse
import hashlib
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.errors import WsbuildError
from wsbuild import inputs

META_FILE = "colcon.meta"
USER_DIR = "metadata"
#: metadata keys wsbuild applies per package, and the build types each reaches
APPLIED = {"cmake-args": ("cmake", "ament_cmake"), "ament-cmake-args": ("ament_cmake",)}
#: where the initial-cache script goes, under the build base
SCRIPT_DIR = Path(".wsbuild")


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
        for values in (self.by_path.get(inputs.realpath(path), {}), self.by_name.get(name, {})):
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


def metadata_files(args: argparse.Namespace, environ: Mapping[str, str], cwd: Path) -> list[Path]:
    """The metadata files that apply, in colcon-metadata's order: the user's, then --metas."""
    from wsbuild.verbs.mixin import config_home

    files: list[Path] = []
    if not getattr(args, "ignore_user_meta", False):
        user = config_home(environ) / USER_DIR
        files += [Path(f) for f in inputs.walk_files(user) if f.endswith(".meta")]
    metas = getattr(args, "metas", None)
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
            data = yaml.safe_load(path.read_text(encoding="utf-8"))
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
                    real = os.path.realpath(path.parent / str(key))
                    target = result.by_path.setdefault(real, {})
                for option, value in values.items():
                    _merge(target, str(option), value)
    return result


@dataclass(frozen=True, slots=True)
class PackageArguments:
    """What the metadata asks of the selected packages: `-D` arguments per package, and a note
    for everything wsbuild does not apply."""

    defines: Mapping[str, tuple[str, ...]]
    notes: tuple[str, ...]


def package_arguments(metadata: Metadata, packages: Mapping[str, tuple[Path, str]],
                      selected: list[str]) -> PackageArguments:
    """`packages`: name → (path, build type)."""
    defines: dict[str, tuple[str, ...]] = {}
    notes: list[str] = []
    for name in selected:
        path, build_type = packages[name]
        values = metadata.for_package(name, path)
        found: list[str] = []
        for key, value in values.items():
            if key not in APPLIED:
                notes.append(f"colcon.meta: '{key}' of {name} is ignored: wsbuild applies "
                             f"cmake-args and ament-cmake-args per package")
                continue
            if build_type not in APPLIED[key]:
                continue
            items = value if isinstance(value, list) else [value]
            for item in map(str, items):
                item = item.strip()
                if item.startswith("-D") and "=" in item:
                    found.append(item)
                elif item:
                    notes.append(f"colcon.meta: {key} '{item}' of {name} is ignored: only -D "
                                 f"arguments reach a single package's CMake")
        if found:
            defines[name] = tuple(found)
    return PackageArguments(defines, tuple(notes))


def _cmake_set(define: str) -> str:
    """`-DNAME[:TYPE]=value` → a `set(… CACHE … FORCE)` line (the package's value wins over
    --cmake-args, as colcon appends metadata arguments to the command line's)."""
    name, _, value = define[2:].partition("=")
    name, _, kind = name.partition(":")
    bracket = "=" * (max((len(r) for r in _equals_runs(value)), default=0) + 1)
    return f'  set({name} [{bracket}[{value}]{bracket}] CACHE {kind or "STRING"} "colcon.meta" FORCE)'


def _equals_runs(text: str) -> list[str]:
    import re

    return re.findall(r"=+", text)


def cache_script(defines: Mapping[str, tuple[str, ...]], build_base: Path) -> str:
    """The initial-cache script: each package's settings, for its build directory only."""
    lines = ["# written by wsbuild from colcon.meta: each package's -D arguments, set when CMake",
             "# configures that package's build directory"]
    for name in sorted(defines):
        lines.append(f'if(CMAKE_BINARY_DIR STREQUAL [==[{build_base / name}]==])')
        lines += [_cmake_set(define) for define in defines[name]]
        lines.append("endif()")
    return "\n".join(lines) + "\n"


def script_path(text: str, build_base: Path) -> Path:
    """Named by its content: a change of the metadata is a change of the CMake arguments, so
    the packages are configured again."""
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    return build_base / SCRIPT_DIR / f"colcon_meta-{digest}.cmake"


def write_script(path: Path, text: str) -> None:
    """Write the script once (its name is its content)."""
    if path.is_file():
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
