"""Staged installs: a package installs into a fresh stage, which replaces its prefix only on success.

So a failed or interrupted build leaves the previous install untouched, and files a package no
longer installs disappear (colcon keeps both half-installed packages and stale files).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from wsbuild.record.installed import Installed, installed_entries
from wsbuild.files import STAGE_DIR, atomic_write
from wsbuild import inputs

#: record, per package, of the files it put into a merged prefix
MERGED_RECORD = ".wsbuild/merged_files.txt"


def stage_path(install_base: Path, package: str) -> Path:
    """Where a package's stage is (`new_stage` makes it)."""
    return install_base / STAGE_DIR / package


def new_stage(install_base: Path, package: str) -> Path:
    stage = stage_path(install_base, package)
    if stage.exists() or stage.is_symlink():
        shutil.rmtree(stage)
    stage.mkdir(parents=True)
    return stage


def discard_stage(stage: Path) -> None:
    shutil.rmtree(stage, ignore_errors=True)


def commit_isolated(stage: Path, prefix: Path) -> None:
    """Swap the stage in for `install/<pkg>` with two renames (same filesystem)."""
    trash = stage.with_name(stage.name + ".old")
    if trash.exists():
        shutil.rmtree(trash)
    if prefix.exists() or prefix.is_symlink():
        os.rename(prefix, trash)
    os.rename(stage, prefix)
    if trash.exists():
        shutil.rmtree(trash)


def _files(root: Path) -> list[str]:
    result = []
    for dirpath, dirnames, filenames in os.walk(root):
        rel = os.path.relpath(dirpath, root)
        for name in filenames + [d for d in dirnames if os.path.islink(os.path.join(dirpath, d))]:
            result.append(os.path.normpath(os.path.join(rel, name)))
    return sorted(result)


def commit_merged(stage: Path, prefix: Path, record: Path,
                  in_place: Iterable[str] = ()) -> None:
    """Move the stage's files into the shared prefix; remove what the previous build installed
    and this one did not. `record` (in build/<pkg>/) lists the package's files; `in_place`
    names files the build wrote straight into the prefix (they count as installed)."""
    staged = _files(stage)
    new_files = sorted(set(staged) | set(in_place))
    old_files = record.read_text().splitlines() if record.exists() else []
    # the list first: a file in the prefix is always on its package's list (what other
    # packages' listings of the prefix leave out: record/merged_owners.py)
    record.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(record, "".join(f"{rel}\n" for rel in sorted(set(new_files) | set(old_files))))
    for rel in sorted(set(old_files) - set(new_files), reverse=True):
        target = prefix / rel
        if target.is_symlink() or target.is_file():
            target.unlink()
        _remove_empty_parents(target.parent, prefix)
    for rel in staged:
        source = stage / rel
        target = prefix / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        if target.is_dir() and not target.is_symlink():
            shutil.rmtree(target)
        os.replace(source, target)
    record.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(record, "".join(f"{rel}\n" for rel in new_files))
    shutil.rmtree(stage, ignore_errors=True)


def _remove_empty_parents(directory: Path, stop: Path) -> None:
    while directory != stop and directory.is_dir() and not any(directory.iterdir()):
        directory.rmdir()
        directory = directory.parent


@contextmanager
def direct_install(prefix: Path, stage: Path) -> Iterator[None]:
    """For installers that must write straight into the final `prefix` (ament's symlink install
    ignores DESTDIR): park the previous install aside, let the installer fill a fresh `prefix`,
    move the result into `stage`, and put the previous install back — also on failure or Ctrl-C.
    (The build runs the two halves as steps of their own, `park_previous_install` and
    `stage_direct_install`, and puts the previous install back on failure with
    `recover_direct_install`.)"""
    park_previous_install(prefix, stage)
    try:
        yield
        stage_direct_install(prefix, stage)
    except BaseException:
        recover_direct_install(prefix, stage)
        raise


def park_previous_install(prefix: Path, stage: Path) -> None:
    """Move the previous install at `prefix` aside (beside the stage) and make `prefix` anew."""
    previous = stage.with_name(stage.name + ".previous")
    recover_direct_install(prefix, stage)
    if prefix.exists() or prefix.is_symlink():
        os.rename(prefix, previous)
    prefix.mkdir(parents=True)


def stage_direct_install(prefix: Path, stage: Path) -> None:
    """Move what the installer wrote into `prefix` into `stage`, and the previous install back."""
    previous = stage.with_name(stage.name + ".previous")
    if stage.exists():
        shutil.rmtree(stage)
    os.rename(prefix, stage)
    if previous.exists() or previous.is_symlink():
        os.rename(previous, prefix)


def recover_direct_install(prefix: Path, stage: Path) -> None:
    """Undo a parked install (a failed, interrupted or killed install step): no half-installed
    package stays behind, the previous install goes back."""
    previous = stage.with_name(stage.name + ".previous")
    if previous.exists() or previous.is_symlink():
        if prefix.is_symlink():
            prefix.unlink()
        elif prefix.exists():
            shutil.rmtree(prefix)
        os.rename(previous, prefix)


def recover_all(install_base: Path) -> None:
    """At the start of a build: restore installs a killed run left parked, drop stale stages."""
    stage_dir = install_base / STAGE_DIR
    if not inputs.exists(stage_dir):
        return
    for parked in sorted(stage_dir.glob("*.previous")):
        name = parked.name[: -len(".previous")]
        recover_direct_install(install_base / name, stage_dir / name)
    shutil.rmtree(stage_dir, ignore_errors=True)


def installed_files(install_base: Path, prefix: Path,
                    only: Iterable[str] | None = None) -> list[Installed]:
    """A package's installed files and symlinks, as its record holds them
    (record/installed.py)."""
    if only is not None:
        paths = [os.path.join(prefix, rel) for rel in only]
    else:
        paths = []
        for dirpath, dirnames, filenames in os.walk(prefix):
            for name in filenames + [d for d in dirnames if os.path.islink(os.path.join(dirpath, d))]:
                paths.append(os.path.join(dirpath, name))
    return installed_entries(str(install_base), paths)
