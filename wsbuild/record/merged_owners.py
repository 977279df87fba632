"""In a merged install every package installs into one prefix, so a directory a build lists
there (a `site-packages` Python's import system or setuptools lists) also holds what packages
it does not depend on installed: built before or after it, as the order falls. Such entries
are no input of its build, as its own are not: a listing leaves them out, and keeps what its
dependencies and anything but the workspace's packages put there.

Who installed what is each package's file list of the merged install (prefix/stage.py's
`MERGED_RECORD`, written before its files reach the prefix), read again whenever it changed."""

from __future__ import annotations

import os
import threading
from collections.abc import Collection
from pathlib import Path

from wsbuild import inputs

_lock = threading.Lock()
#: install base -> (build base, the file list's path under build/<pkg>)
_layouts: dict[str, tuple[Path, str]] = {}
#: file list path -> (its stat signature, the files it lists)
_lists: dict[str, tuple[tuple[int, int, int], tuple[str, ...]]] = {}


def register(install_base: Path, build_base: Path, file_list: str) -> None:
    """The run's install base is merged: its packages' file lists are at
    `build_base/<pkg>/file_list`."""
    with _lock:
        _layouts[str(install_base).rstrip(os.sep)] = (build_base, file_list)


def in_merged_install(path: str) -> bool:
    """Whether `path` lies in a merged install base: a listing of it changes during a build
    only by what the build leaves out (its own entries, those of packages it does not depend
    on, which may build meanwhile; its dependencies finished before it started)."""
    with _lock:
        bases = list(_layouts)
    return any((path + os.sep).startswith(base + os.sep) for base in bases)


def others_in(install_base: str, rel: str, package: str, keep: Collection[str]
              ) -> frozenset[str]:
    """The names in the directory `rel` of the merged install base that packages other than
    `package` and those in `keep` installed (empty where the install is not merged)."""
    with _lock:
        layout = _layouts.get(install_base.rstrip(os.sep))
    if layout is None or not package:
        return frozenset()

    build_base, file_list = layout
    prefix = rel + os.sep if rel else ""
    found: set[str] = set()
    try:
        packages = sorted(inputs.listdir(build_base))
    except OSError:
        packages = []
    for other in packages:
        if other == package or other in keep:
            continue
        for path in _files(build_base / other / file_list):
            if path.startswith(prefix) and len(path) > len(prefix):
                found.add(path[len(prefix):].split(os.sep, 1)[0])
    return frozenset(found)


def _files(path: Path) -> tuple[str, ...]:
    try:
        info = inputs.stat(path)
    except OSError:
        return ()
    signature = (info.st_ino, info.st_size, info.st_mtime_ns)
    with _lock:
        held = _lists.get(str(path))
    if held is not None and held[0] == signature:
        return held[1]
    try:
        files = tuple(line for line in inputs.read_text(path).splitlines() if line.strip())
    except OSError:
        return ()
    with _lock:
        _lists[str(path)] = (signature, files)
    return files
