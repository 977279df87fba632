"""One build per workspace at a time: an advisory lock on a file in build/. A run that was
stopped (Ctrl-C, SIGTERM, SIGHUP) keeps it until this process ends: the next build starts
nothing while the stopped wsbuild or any process it started is alive."""

from __future__ import annotations

import fcntl
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from wsbuild.errors import WorkspaceError

TYPE_CHECKING = False
if TYPE_CHECKING:
    from wsbuild.engine.process import ProcessRegistry

#: the locks of runs of this process that were stopped, kept open until it exits (the kernel
#: releases a lock when the last descriptor of its file closes, so after every thread of
#: wsbuild is done with the workspace, and after its last line is written)
_KEPT: list[int] = []


@contextmanager
def workspace_lock(build_base: Path, *, wait: bool, on_wait: Callable[[str], None],
                   registry: ProcessRegistry | None = None) -> Iterator[None]:
    """Hold `build/.wsbuild.build.lock`; the kernel releases it if wsbuild dies, so it never
    goes stale. The lock held is the one at that path once it is taken: a file removed or
    replaced while this run waited (`wsbuild clean` deleting build/) is locked anew, so two
    builds never run in one workspace at once. When the run was stopped (`registry` cancelled)
    the lock is not given back: every process the run started is swept once more, and the
    lock stays held until this process exits."""
    _release_kept()  # a stopped run of this same process (cli.main called again) is over
    path = build_base / ".wsbuild.build.lock"
    waited = False
    while True:
        build_base.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "unknown"
                if not wait:
                    raise WorkspaceError(
                        f"another wsbuild (pid {holder}) is building this workspace",
                        path=path,
                        hint="wait for it to finish, or drop --no-wait to wait automatically",
                    ) from None
                if not waited:
                    on_wait(f"another wsbuild (pid {holder}) is building this workspace; "
                            "waiting for it to finish...")
                    waited = True
                fcntl.flock(fd, fcntl.LOCK_EX)
            if not _is_at(fd, path):
                os.close(fd)
                continue
        except BaseException:
            os.close(fd)
            raise
        break
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield
    finally:
        if _stopped(registry):
            _KEPT.append(fd)
        else:
            os.close(fd)


def _stopped(registry: ProcessRegistry | None) -> bool:
    """Whether this run was stopped; if so, every process it started is gone on return (what
    the run's own sweep could not end within its bounds is swept once more)."""
    if registry is None:
        process = sys.modules.get("wsbuild.engine.process")
        if process is None:
            return False
        registry = process.REGISTRY
    if not registry.cancelled.is_set():
        return False
    from wsbuild.engine.process import living_descendants  # lazy: off the replayed no-op

    if living_descendants():
        registry.terminate_all()
    return True


def _release_kept() -> None:
    while _KEPT:
        os.close(_KEPT.pop())


def _is_at(fd: int, path: Path) -> bool:
    """Whether the open file `fd` is still the file at `path`."""
    try:
        at = os.stat(path)
    except OSError:
        return False
    held = os.fstat(fd)
    return (held.st_dev, held.st_ino) == (at.st_dev, at.st_ino)
