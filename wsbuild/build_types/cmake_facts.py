"""What the CMake build types know before they decide a package's steps: the facts of the run
(the Ninja to build with and its version, found once) and the state of a package's build
directory (its CMake cache's generator and symlink-install setting, the last configure's
record, read once when its context is made), so that `steps()` reads and runs nothing."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from wsbuild.record.configured import Configured, read_configured
from wsbuild.patterns import lazy

#: the first Ninja release that is a GNU make jobserver client
NINJA_JOBSERVER = (1, 13)


@dataclass(frozen=True, slots=True)
class NinjaTool:
    """The Ninja a build runs: where it is and its version."""

    path: Path
    version: tuple[int, ...]

    @property
    def jobserver(self) -> bool:
        return self.version >= NINJA_JOBSERVER


_ninja_found: dict[tuple[str, ...], NinjaTool | None] = {}


def _ninja_version(path: Path) -> tuple[int, ...] | None:
    try:
        done = subprocess.run([str(path), "--version"], capture_output=True, text=True,
                              timeout=30, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    match = re.match(r"(\d+(?:\.\d+)*)", done.stdout.strip())
    if done.returncode != 0 or not match:
        return None
    return tuple(int(part) for part in match.group(1).split("."))


def find_ninja(environ: Mapping[str, str]) -> NinjaTool | None:
    """The `ninja` to build with: the first jobserver client (≥ 1.13) among those on PATH and
    next to wsbuild's interpreter, else the first one found; None when there is none."""
    candidates: list[Path] = []
    for directory in [*environ.get("PATH", "").split(os.pathsep), str(Path(sys.executable).parent)]:
        if directory:
            path = Path(directory) / "ninja"
            if path not in candidates and path.is_file() and os.access(path, os.X_OK):
                candidates.append(path)
    key = tuple(str(c) for c in candidates)
    if key not in _ninja_found:
        tools = [NinjaTool(c, v) for c in candidates if (v := _ninja_version(c)) is not None]
        _ninja_found[key] = next((t for t in tools if t.jobserver), tools[0] if tools else None)
    return _ninja_found[key]


def user_generator(cmake_args: Sequence[str], environ: Mapping[str, str]) -> str | None:
    """The generator the user chose: `-G X` / `-GX` in --cmake-args (the last wins), else
    CMake's own `CMAKE_GENERATOR` variable."""
    chosen = None
    for index, arg in enumerate(cmake_args):
        if arg == "-G" and index + 1 < len(cmake_args):
            chosen = cmake_args[index + 1]
        elif arg.startswith("-G") and len(arg) > 2:
            chosen = arg[2:]
    return chosen or environ.get("CMAKE_GENERATOR") or None


@dataclass(frozen=True, slots=True)
class CMakeFacts:
    """What the CMake build types find once per run: the Ninja to build with."""

    ninja: NinjaTool | None


@dataclass(frozen=True, slots=True)
class CMakeState:
    """What a package's build directory holds before its build: read once, when the package's
    context is made, so that the steps are decided without reading anything."""

    #: CMakeCache.txt is there
    cache: bool = False
    #: the generator the cache was configured with
    generator: str | None = None
    #: the cache's AMENT_CMAKE_SYMLINK_INSTALL (None: not set)
    symlink_install: bool | None = None
    #: what the last configure used (record/configured.py), None when none is known
    configured: Configured | None = None


_SYMLINK_INSTALL = lazy(r"^AMENT_CMAKE_SYMLINK_INSTALL:[A-Z]+=(.*)$", re.MULTILINE)
_GENERATOR = lazy(r"^CMAKE_GENERATOR:INTERNAL=(.*)$", re.MULTILINE)


def read_cmake_state(build_dir: Path) -> CMakeState:
    """What `build_dir` holds: its CMake cache's generator and symlink-install setting, and
    what the last configure used."""
    try:
        text: str | None = (build_dir / "CMakeCache.txt").read_text(errors="replace")
    except OSError:
        text = None
    generator = symlink = None
    if text is not None:
        found = _GENERATOR.search(text)
        generator = found.group(1).strip() if found else None
        found = _SYMLINK_INSTALL.search(text)
        symlink = found is not None and found.group(1).strip().upper() in (
            "1", "ON", "TRUE", "YES", "Y")
    return CMakeState(cache=text is not None, generator=generator, symlink_install=symlink,
                      configured=read_configured(build_dir))
