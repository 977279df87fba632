"""One build per workspace at a time: an advisory lock on a file in build/."""

from __future__ import annotations

import fcntl
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from wsbuild.errors import WorkspaceError


@contextmanager
def workspace_lock(build_base: Path, *, wait: bool,
                   on_wait: Callable[[str], None]) -> Iterator[None]:
    """Hold `build/.wsbuild.build.lock`; the kernel releases it if wsbuild dies, so it never
    goes stale. The lock held is the one at that path once it is taken: a file removed or
    replaced while this run waited (`wsbuild clean` deleting build/) is locked anew, so two
    builds never run in one workspace at once."""
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
        os.close(fd)


def _is_at(fd: int, path: Path) -> bool:
    """Whether the open file `fd` is still the file at `path`."""
    try:
        at = os.stat(path)
    except OSError:
        return False
    held = os.fstat(fd)
    return (held.st_dev, held.st_ino) == (at.st_dev, at.st_ino)
