"""The local cache tier: ~/.cache/wsbuild (or $XDG_CACHE_HOME/wsbuild), the same layout as the
HTTP tier (cas/<sha256>, ac/<sha256>), bounded in size with least-recently-used eviction.

Every write goes to a temporary file that is renamed into place, so readers never see half an
entry and two builds filling the same entry at once leave one good one.
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from wsbuild.cache.action_result import parse_action_result
from wsbuild.cache.archive import file_digest
from wsbuild.cache.key import is_digest, parse_variants
from wsbuild.cache.settings import DEFAULT_MAX_BYTES

#: temporary files older than this belong to a killed run
_STALE_SECONDS = 3600


@dataclass(frozen=True, slots=True)
class CacheStats:
    """What the local cache holds: entries, blobs, bytes, and its size limit."""

    directory: Path
    entries: int
    blobs: int
    bytes: int
    max_bytes: int


@dataclass(frozen=True, slots=True)
class Pruned:
    """What a prune of the local cache removed."""

    blobs: int
    entries: int
    bytes: int


class LocalCache:
    """cas/ holds packed installs by their sha256; ac/ maps a cache key's address to a record."""

    def __init__(self, root: Path, max_bytes: int = DEFAULT_MAX_BYTES) -> None:
        self.root = root
        self.max_bytes = max_bytes
        self.cas = root / "cas"
        self.ac = root / "ac"
        self.tmp = root / "tmp"
        self._ensured = False

    def ensure(self) -> None:
        if self._ensured:
            return
        for directory in (self.cas, self.ac, self.tmp):
            directory.mkdir(parents=True, exist_ok=True)
        self._ensured = True

    # -- reading -------------------------------------------------------------------------
    def get_action(self, address: str) -> bytes | None:
        path = self.ac / address
        try:
            data = path.read_bytes()
        except OSError:
            return None
        _touch(path)
        return data

    def blob_path(self, digest: str) -> Path | None:
        if not is_digest(digest):
            return None
        path = self.cas / digest
        if not path.is_file():
            return None
        _touch(path)  # least recently *used* goes first
        return path

    # -- writing -------------------------------------------------------------------------
    def temp_file(self) -> Path:
        """A new empty file in tmp/ (same filesystem as cas/, so it can be renamed in)."""
        self.ensure()
        fd, name = tempfile.mkstemp(dir=self.tmp, prefix="in-")
        os.close(fd)
        return Path(name)

    def put_blob(self, digest: str, source: Path) -> Path:
        """Move `source` (a file from temp_file) into cas/ under `digest`."""
        if not is_digest(digest):
            raise ValueError(f"not a sha256: {digest!r}")
        target = self.cas / digest
        os.replace(source, target)
        return target

    def put_action(self, address: str, data: bytes) -> None:
        if not is_digest(address):
            raise ValueError(f"not a sha256: {address!r}")
        temp = self.temp_file()
        temp.write_bytes(data)
        os.replace(temp, self.ac / address)

    def forget(self, address: str | None = None, digest: str | None = None) -> None:
        """Drop a record and/or blob found bad, so it is not tried again."""
        for directory, name in ((self.ac, address), (self.cas, digest)):
            if name and is_digest(name):
                try:
                    (directory / name).unlink()
                except OSError:
                    pass

    # -- housekeeping --------------------------------------------------------------------
    def stats(self) -> CacheStats:
        """What the cache holds: its entries (each stored build once, though it is found
        under its key and its variant) and blobs."""
        blobs = list(_files(self.cas))
        entries = {(record.digest, record.record_digest) for path, _, _ in _files(self.ac)
                   if (record := parse_action_result(_read(path))) is not None}
        return CacheStats(self.root, entries=len(entries), blobs=len(blobs),
                          bytes=sum(size for _, size, _ in blobs), max_bytes=self.max_bytes)

    def prune(self, max_bytes: int | None = None) -> Pruned:
        """Evict least recently used blobs until the cache fits `max_bytes`; then drop records
        whose blob is gone and temporary files left by killed runs."""
        limit = self.max_bytes if max_bytes is None else max_bytes
        blobs = sorted(_files(self.cas), key=lambda item: item[2])  # oldest use first
        total = sum(size for _, size, _ in blobs)
        removed = freed = 0
        for path, size, _ in blobs:
            if total <= limit:
                break
            try:
                path.unlink()
            except OSError:
                continue
            total -= size
            removed += 1
            freed += size
        entries = self._drop_dangling_records() if removed else 0
        now = time.time()
        for path, _, mtime in _files(self.tmp):
            if now - mtime > _STALE_SECONDS:
                try:
                    path.unlink()
                except OSError:
                    pass
        return Pruned(blobs=removed, entries=entries, bytes=freed)

    def _drop_dangling_records(self) -> int:
        dropped = 0
        for path, _, _ in _files(self.ac):
            record = parse_action_result(_read(path))
            if record is None or not (self.cas / record.digest).is_file() or (
                    record.record_digest and not (self.cas / record.record_digest).is_file()):
                try:
                    path.unlink()
                    dropped += 1
                except OSError:
                    pass
        return dropped

    def verify(self) -> list[str]:
        """Check every blob against its name and every record against its blob; remove and
        list what is bad."""
        problems: list[str] = []
        for path, size, _ in _files(self.cas):
            try:
                digest, _ = file_digest(path)
            except OSError as error:
                problems.append(f"cas/{path.name}: unreadable ({error.strerror})")
                continue
            if digest != path.name:
                problems.append(f"cas/{path.name}: content does not match its digest (removed)")
                path.unlink(missing_ok=True)
        for path, _, _ in _files(self.ac):
            data = _read(path)
            record = parse_action_result(data)
            if record is None and parse_variants(data) is not None:
                continue  # a key's list of its variants
            if record is None:
                problems.append(f"ac/{path.name}: not a wsbuild cache record (removed)")
                path.unlink(missing_ok=True)
            elif not (self.cas / record.digest).is_file():
                problems.append(f"ac/{path.name}: its archive cas/{record.digest} is missing (removed)")
                path.unlink(missing_ok=True)
            elif (self.cas / record.digest).stat().st_size != record.size:
                problems.append(f"ac/{path.name}: archive size differs from the record (removed)")
                path.unlink(missing_ok=True)
            elif record.record_digest and not (self.cas / record.record_digest).is_file():
                problems.append(f"ac/{path.name}: its package record cas/{record.record_digest} "
                                "is missing (removed)")
                path.unlink(missing_ok=True)
        return problems


def _touch(path: Path) -> None:
    try:
        os.utime(path)
    except OSError:
        pass


def _read(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except OSError:
        return b""


def _files(directory: Path) -> list[tuple[Path, int, float]]:
    """(path, size, mtime) of the plain files in `directory`."""
    result = []
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return []
    for entry in entries:
        try:
            if entry.is_file(follow_symlinks=False):
                info = entry.stat(follow_symlinks=False)
                result.append((Path(entry.path), info.st_size, info.st_mtime))
        except OSError:
            continue
    return result
