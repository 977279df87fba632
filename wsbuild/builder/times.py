"""Times that did not advance: make and Ninja compare modification times only, so a file
whose content changed while its time did not advance past the last build (`cp -p`, `tar x`,
`touch -d`, some sync tools; CMake installs a file with its source's time cut to the second)
would leave the outputs built from the old content. Inside the workspace wsbuild sets such a
file's time forward (the package's own sources, what its last build read of a dependency's
install); outside it they are not wsbuild's to touch, and the package is built from scratch
instead (builder/package.py)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from wsbuild.builder.plan import PackagePlan
from wsbuild.inputs import ABSENT
from wsbuild.record.model import RECORD_FILE
from wsbuild.record.outside import Digests


def changed_unseen(planned: PackagePlan, build_dir: Path, root: Path, digests: Digests, *,
                   inside: bool) -> list[str]:
    """The files the last build read whose content changed since while their modification
    time did not advance past the last build's end, inside the workspace at `root`
    (`inside`) or outside it."""
    previous = planned.previous
    if previous is None:
        return []
    try:  # written right after the last build's outputs
        built = os.stat(build_dir / RECORD_FILE).st_mtime_ns
    except OSError:
        return []
    base = str(root.absolute()) + os.sep
    found = []
    for path, seen in previous.outside.files.items():
        if (path + os.sep).startswith(base) != inside:
            continue
        signature = digests.signature(path)
        if signature == seen.signature or signature == ABSENT or signature[3] > built \
                or digests.file(path, signature) == seen.digest:
            continue
        found.append(path)
    return found


def advance_changed_files(planned: PackagePlan, build_dir: Path, root: Path, digests: Digests,
                          log: Callable[[str], None]) -> dict[str, str]:
    """Set forward the time of the package's own files edited so, and of what its last build
    read inside the workspace that changed so; the files outside the package so touched, with
    their content's digest now (what the steps will read: record/outside.py's racy rule)."""
    own = [planned.source_dir / rel for rel in planned.backdated]
    outside = changed_unseen(planned, build_dir, root, digests, inside=True)
    touched: dict[str, str] = {}
    for path in [*own, *map(Path, outside)]:
        try:
            os.utime(path)
        except OSError:
            continue
        digests.advanced(str(path))
        if str(path) in outside:
            touched[str(path)] = digests.file(str(path), digests.signature(str(path)))
        log(f"Set the modification time of {path} to now: its content changed, its time did "
            "not advance, and the build system compares times only")
    return touched


def redo_for_backdated(planned: PackagePlan, build_dir: Path, root: Path, digests: Digests,
                       log: Callable[[str], None]) -> tuple[str, ...]:
    """The steps to redo for a file outside the workspace at `root` that changed with a time
    that did not advance: the build, from scratch (its build type's reading of "build" in
    `PackageContext.redo`)."""
    backdated = changed_unseen(planned, build_dir, root, digests, inside=False)
    if not backdated:
        return ()
    log(f"{backdated[0]} changed, its modification time did not advance and it lies outside "
        "the workspace: building from scratch")
    return ("build",)
