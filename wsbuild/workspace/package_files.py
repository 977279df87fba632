"""The files of a package as its build sees them: every file below its directory but hidden
ones, editor and bytecode leftovers, build/, install/, log/, caches, egg-info and directories
marked COLCON_IGNORE. The build's fingerprint (builder/fingerprint.py) and a test result's key
(testing/cached_result.py) walk the same files."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

from wsbuild import inputs

#: directories inside a package that never affect its build
SKIP_DIRS = frozenset({"__pycache__", "build", "install", "log"})
SKIP_SUFFIXES = (".pyc", ".pyo", ".swp", "~")
#: what a directory that cannot be listed is reported as
UNREADABLE_DIR = "/\0unreadable"


def package_files(root: Path) -> Iterator[tuple[str, os.DirEntry[str] | None]]:
    """(path relative to `root`, its entry) of every file, directories depth first; a
    directory that cannot be listed comes as (its path + UNREADABLE_DIR, None). Each listing
    is a declared input (wsbuild/inputs.py)."""
    stack = [""]
    while stack:
        rel_dir = stack.pop()
        directory = os.path.join(root, rel_dir) if rel_dir else str(root)
        try:
            entries = inputs.scandir(directory)
        except OSError:
            yield rel_dir + UNREADABLE_DIR, None
            continue
        if rel_dir and any(e.name == "COLCON_IGNORE" for e in entries):
            continue
        for entry in entries:
            name = entry.name
            if name.startswith(".") or name.endswith(SKIP_SUFFIXES):
                continue
            rel = f"{rel_dir}/{name}" if rel_dir else name
            try:
                is_dir = entry.is_dir()  # follows symlinks
            except OSError:
                is_dir = False
            if is_dir:
                if name not in SKIP_DIRS and not name.endswith(".egg-info"):
                    stack.append(rel)
                continue
            yield rel, entry
