"""What the CMake build types' steps that run in wsbuild do (each a `Step(label, action)` of
cmake.py's recipe, shown by `--dry-run`): drop a cache (with or without CMake's files) or
empty a build directory, forget what the last configure used (record/configured.py).
(Staging the install: build_types/staging.py.)"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from wsbuild.build_types import PackageContext
from wsbuild.record.configured import forget_configured

#: what stays when a build directory is emptied: wsbuild's own records and markers
KEPT_IN_BUILD_DIRECTORY = frozenset({".wsbuild", "COLCON_IGNORE", "AMENT_IGNORE"})


def empty_build_directory(build_dir: Path) -> None:
    """Remove what CMake and the build wrote into `build_dir` (a configure from scratch)."""
    for entry in os.scandir(build_dir):
        if entry.name in KEPT_IN_BUILD_DIRECTORY:
            continue
        if entry.is_dir(follow_symlinks=False):
            shutil.rmtree(entry.path)
        else:
            os.unlink(entry.path)


def remove_cache(ctx: PackageContext, *, warning: str) -> None:
    if warning:
        ctx.warn(warning)
    (ctx.build_dir / "CMakeCache.txt").unlink(missing_ok=True)
    shutil.rmtree(ctx.build_dir / "CMakeFiles", ignore_errors=True)


def forget_cache(ctx: PackageContext) -> None:
    (ctx.build_dir / "CMakeCache.txt").unlink(missing_ok=True)


def empty(ctx: PackageContext, *, why: str) -> None:
    # information: the option was switched on purpose, and its build directory follows
    ctx.note(f"built {why}: building it from scratch")
    empty_build_directory(ctx.build_dir)


def forget_configure_record(ctx: PackageContext) -> None:
    forget_configured(ctx.build_dir)
