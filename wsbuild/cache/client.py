"""The build's view of the cache: look a key up in the local tier, then the remote one; restore
an entry into a stage; store a finished install in both.

Never trust: a record or archive that does not verify is refused with one warning and the
package builds as usual. Never block: the first failure to reach the server turns the remote
tier off for the rest of the run (one warning); uploads run on a background thread.
"""

from __future__ import annotations

import os
import queue
import shutil
import threading
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.cache.archive import RefusedEntry, file_digest, pack, unpack
from wsbuild.cache.key import CacheKey
from wsbuild.cache.local import LocalCache
from wsbuild.cache.record import Record, parse_record
from wsbuild.cache.settings import CacheSettings, default_cache_dir

if TYPE_CHECKING:
    from wsbuild.cache.http import HttpCache

Warn = Callable[[str], None]


@dataclass(frozen=True, slots=True)
class Restored:
    source: str  # "local" or the remote URL
    digest: str
    members: int


class BuildCache:
    def __init__(self, local: LocalCache, remote: HttpCache | None = None, *,
                 read_only: bool = False, warn: Warn = lambda text: None) -> None:
        self.local = local
        self.remote = remote
        self.read_only = read_only
        self._warn = warn
        self._lock = threading.Lock()
        self._uploads_on = remote is not None and not read_only
        self._stored = False
        self._queue: queue.Queue[tuple[str, Path, str, bytes] | None] = queue.Queue()
        self._uploader: threading.Thread | None = None

    @classmethod
    def open(cls, settings: CacheSettings, *, environ: Mapping[str, str] | None = None,
             warn: Warn = lambda text: None) -> BuildCache | None:
        if not settings.enabled:
            return None
        local = LocalCache(settings.directory or default_cache_dir(os.environ),
                           settings.max_bytes)
        remote = None
        if settings.url:
            from wsbuild.cache.http import HttpCache  # only with a server: http.client costs

            remote = HttpCache(settings.url, environ=environ, timeout=settings.timeout)
        return cls(local, remote, read_only=settings.read_only, warn=warn)

    # -- failures ------------------------------------------------------------------------
    def _remote_off(self, reason: str) -> None:
        with self._lock:
            if self.remote is None:
                return
            self.remote = None
            self._uploads_on = False
        self._warn(f"cache server unusable ({reason}); the remote cache is off for this run")

    def _uploads_off(self, reason: str) -> None:
        with self._lock:
            if not self._uploads_on:
                return
            self._uploads_on = False
        self._warn(f"cache server refuses uploads ({reason}); not uploading for this run")

    def _refuse(self, key: CacheKey, reason: str, *, local: bool, digest: str | None) -> None:
        if local:
            self.local.forget(key.address, digest)
        self._warn(f"cache entry for {key.package} refused ({reason}); building it")

    # -- restoring -----------------------------------------------------------------------
    def restore(self, key: CacheKey, dest: Path) -> Restored | None:
        """Unpack `key`'s entry into the empty directory `dest`; None on a miss or a refused
        entry (then `dest` may hold debris: the caller discards it)."""
        address = key.address
        data = self.local.get_action(address)
        remote = self.remote
        from_local = data is not None
        if data is None and remote is not None:
            from wsbuild.cache.http import CacheUnavailable

            try:
                data = remote.get_action(address)
            except CacheUnavailable as error:
                self._remote_off(str(error))
                return None
        if data is None:
            return None
        record = parse_record(data)
        if record is None or record.package != key.package:
            self._refuse(key, "not a wsbuild record for this package", local=from_local,
                         digest=None)
            return None
        blob = self.local.blob_path(record.digest)
        blob_is_local = blob is not None
        if blob is None:
            if remote is None:
                if from_local:
                    self.local.forget(address)  # the blob was evicted
                return None
            blob = self._download(key, record, remote)
            if blob is None:
                return None
        try:
            digest, size = file_digest(blob)
            if (digest, size) != (record.digest, record.size):
                raise RefusedEntry("archive does not match its digest")
            members = unpack_file(blob, dest)
        except (RefusedEntry, OSError) as error:
            self._refuse(key, str(error), local=from_local or blob_is_local,
                         digest=record.digest if blob_is_local else None)
            if not blob_is_local:
                blob.unlink(missing_ok=True)
            return None
        source = "local"
        if not blob_is_local:
            source = remote.display if remote is not None else "remote"
            if self.read_only:
                blob.unlink(missing_ok=True)
            else:
                # keep it: the next clean build on this machine needs no network
                self.local.put_blob(record.digest, blob)
                self.local.put_action(address, record.encode())
                self._stored = True
        return Restored(source, record.digest, members)

    def _download(self, key: CacheKey, record: Record, remote: HttpCache) -> Path | None:
        from wsbuild.cache.http import CacheUnavailable, TruncatedDownload

        temp = self.local.temp_file()
        try:
            with open(temp, "wb") as out:
                found = remote.fetch_blob(record.digest, out)
        except CacheUnavailable as error:
            temp.unlink(missing_ok=True)
            self._remote_off(str(error))
            return None
        except TruncatedDownload:
            temp.unlink(missing_ok=True)
            self._refuse(key, "truncated download", local=False, digest=None)
            return None
        if not found:
            temp.unlink(missing_ok=True)
            return None
        return temp

    # -- storing -------------------------------------------------------------------------
    def store(self, key: CacheKey, root: Path, files: Iterable[str] | None = None) -> str | None:
        """Pack `root` (or `files` below it) as `key`'s entry; None when stored, else why not."""
        if self.read_only:
            return "the cache is read-only for this run"
        temp = self.local.temp_file()
        try:
            with open(temp, "wb") as out:
                digest, size = pack(root, out, files)
        except (RefusedEntry, OSError) as error:
            temp.unlink(missing_ok=True)
            return f"not cached: {error}"
        blob = self.local.put_blob(digest, temp)
        record = Record(key.package, digest, size).encode()
        self.local.put_action(key.address, record)
        with self._lock:
            self._stored = True
            upload = self._uploads_on
            if upload and self._uploader is None:
                self._uploader = threading.Thread(target=self._upload_loop,
                                                  name="wsbuild-cache-upload", daemon=True)
                self._uploader.start()
        if upload:
            self._queue.put((digest, blob, key.address, record))
        return None

    def _upload_loop(self) -> None:
        from wsbuild.cache.http import CacheRejected, CacheUnavailable

        while (item := self._queue.get()) is not None:
            digest, blob, address, record = item
            remote = self.remote
            if remote is None or not self._uploads_on:
                continue
            try:
                if not remote.has_blob(digest):
                    remote.put_blob(digest, blob)
                remote.put_action(address, record)
            except CacheRejected as error:
                self._uploads_off(str(error))
            except CacheUnavailable as error:
                self._remote_off(str(error))
            except OSError:
                continue  # evicted locally meanwhile by another run: nothing to upload

    def close(self, *, wait: bool = True) -> None:
        """Finish uploads (unless `wait` is False, e.g. after Ctrl-C) and evict old entries."""
        if self._uploader is not None:
            self._queue.put(None)
            if wait:
                self._uploader.join()
        if self.remote is not None:
            self.remote.close()
        if self._stored and wait:
            self.local.prune()


def unpack_file(path: Path, dest: Path) -> int:
    with open(path, "rb") as handle:
        return unpack(handle, dest)


def clear_directory(path: Path) -> None:
    """Empty `path` (a stage a refused entry was unpacked into)."""
    shutil.rmtree(path, ignore_errors=True)
    path.mkdir(parents=True, exist_ok=True)
