"""Content digests of files outside the workspace kept across runs, by path and stat signature
(`~/.cache/wsbuild-observe/digests.memo`, private to the user): a new workspace or a fresh
clone does not hash the compiler, the ROS wheels' libraries and the interpreter's modules
again, only what changed since (git's index, ccache's direct mode do the same).

A digest is taken from the memo only for the signature it was taken with (mode, inode, size,
modification and change times), and only when the file's times lay more than `RACY_NS` before
the digest was taken: a file written again within the file system's time granularity keeps
its times, so a digest taken then is never trusted later (git's "racily clean" rule).

The memo is read at its first use in a process and written (merged with what other runs
wrote meanwhile) when a run that is not a dry run ends; one of another shape, or unreadable,
is no memo."""

from __future__ import annotations

import marshal
import os
import threading
from pathlib import Path

from wsbuild import inputs
from wsbuild.files import atomic_write, private_directory

#: a digest taken within this many nanoseconds after the file's last change is not kept
RACY_NS = 2_000_000_000
#: the most digests kept (the most recently taken ones)
MAX_ENTRIES = 200_000
_VERSION = 1


class FileDigests:
    """The memo of one user's cache directory."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._lock = threading.Lock()
        self._held: dict[str, tuple[tuple[int, ...], str, int]] | None = None
        self._new: dict[str, tuple[tuple[int, ...], str, int]] = {}

    def _entries(self) -> dict[str, tuple[tuple[int, ...], str, int]]:
        if self._held is None:
            self._held = _read(self.path)
        return self._held

    def get(self, path: str, signature: tuple[int, ...]) -> str | None:
        """The digest of the file at `path` with `signature`, when a run took it safely."""
        with self._lock:
            held = self._new.get(path) or self._entries().get(path)
        if held is None or held[0] != signature:
            return None
        return held[1]

    def put(self, path: str, signature: tuple[int, ...], digest: str, taken_ns: int) -> None:
        """Keep the digest taken at `taken_ns` of the file at `path` with `signature`, unless
        the file changed too shortly before to trust its times."""
        if len(signature) < 5 or max(signature[3], signature[4]) > taken_ns - RACY_NS:
            return
        with self._lock:
            self._new[path] = (signature, digest, taken_ns)

    def save(self) -> None:
        """Write the memo with what this process took, merged with what is on disk now."""
        with self._lock:
            if not self._new:
                return
            new, self._new = self._new, {}
        merged = {**_read(self.path), **new}
        if len(merged) > MAX_ENTRIES:
            newest = sorted(merged.items(), key=lambda item: item[1][2])[-MAX_ENTRIES:]
            merged = dict(newest)
        data = marshal.dumps([_VERSION, {p: [list(s), d, t] for p, (s, d, t) in merged.items()}])

        try:
            private_directory(self.path.parent)
            atomic_write(self.path, data, mode=0o600)
        except OSError:
            return  # a memo is never worth failing the run
        with self._lock:
            self._held = merged


def _read(path: Path) -> dict[str, tuple[tuple[int, ...], str, int]]:
    inputs.declare_memo(path)
    try:
        with open(path, "rb") as handle:
            version, entries = marshal.loads(handle.read())
        if version != _VERSION or not isinstance(entries, dict):
            return {}
        return {str(p): (tuple(s), str(d), int(t)) for p, (s, d, t) in entries.items()}
    except (OSError, EOFError, ValueError, TypeError):
        return {}


_memos: dict[str, FileDigests] = {}
_memos_lock = threading.Lock()


def file_digests(directory: Path) -> FileDigests:
    """The memo kept in `directory` (one per process)."""
    key = os.path.abspath(directory)
    with _memos_lock:
        memo = _memos.get(key)
        if memo is None:
            memo = _memos[key] = FileDigests(Path(key) / "digests.memo")
        return memo


def save_file_digests() -> None:
    """Write every memo this process added to."""
    with _memos_lock:
        memos = list(_memos.values())
    for memo in memos:
        memo.save()
