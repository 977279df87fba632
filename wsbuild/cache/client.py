"""The build's view of the cache: look a key up in the local tier, then the remote one; restore
an entry into a stage; store a finished install in both.

Never trust: a record or archive that does not verify is refused with one warning and the
package builds as usual. Never block: the first failure to reach the server turns the remote
tier off for the rest of the run (one warning); uploads run on a background thread.
"""

from __future__ import annotations

import os
import queue
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.cache.archive import RefusedEntry, file_digest, pack, unpack
from wsbuild.cache.key import MAX_VARIANTS, CacheKey, variant_list, with_variant
from wsbuild.cache.local import LocalCache
from wsbuild.cache.action_result import ActionResult, parse_action_result
from wsbuild.cache.settings import CacheSettings, default_cache_dir

if TYPE_CHECKING:
    from wsbuild.cache.http import HttpCache

Warn = Callable[[str], None]


#: the largest package record an entry may carry (a C++ package's: tens of KiB)
MAX_RECORD_BYTES = 64 * 1024 * 1024


@dataclass(frozen=True, slots=True)
class Found:
    """A cache entry found for a key, with the package record it was built with."""

    record: ActionResult
    from_local: bool
    #: the package record the entry was built with (record/model.py's JSON, its digest
    #: checked): None when the entry carries none or it could not be fetched (such an entry is
    #: never restored)
    package_record: bytes | None = None


@dataclass(frozen=True, slots=True)
class Restored:
    """A cache entry unpacked into a stage: from where, its digest, how many members."""

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
        self._queue: queue.Queue[tuple[object, ...] | None] = queue.Queue()
        self._worker: threading.Thread | None = None
        #: what background stores could not do (for the run's log)
        self.notes: list[str] = []
        #: time the cache's thread spent packing and uploading, and the CPU time of that (the
        #: rest is waiting for the disk and the server)
        self.background_seconds = 0.0
        self.background_cpu_seconds = 0.0

    @classmethod
    def open(cls, settings: CacheSettings, *, environ: Mapping[str, str] | None = None,
             warn: Warn = lambda text: None) -> BuildCache | None:
        if not settings.enabled:
            return None
        local = LocalCache(settings.directory or default_cache_dir(os.environ),
                           settings.max_bytes)
        remote = None
        if settings.url:
            from wsbuild.cache.http import HttpCache  # lazy: off builds with no server

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
    def find(self, key: CacheKey) -> Found | None:
        """The record of `key`'s entry, locally or on the server; None on a miss (cheap: no
        archive is touched, nothing is written)."""
        address = key.address
        data = self.local.get_action(address)
        remote = self.remote
        from_local = data is not None
        if data is None and remote is not None:
            from wsbuild.cache.http import CacheUnavailable  # lazy: off builds with no server

            try:
                data = remote.get_action(address)
            except CacheUnavailable as error:
                self._remote_off(str(error))
                return None
        if data is None:
            return None
        record = parse_action_result(data)
        if record is None or record.package != key.package:
            self._refuse(key, "not a wsbuild record for this package", local=from_local,
                         digest=None)
            return None
        return Found(record, from_local, self._package_record(key, record))

    def variants(self, key: CacheKey) -> list[tuple[str, ...]]:
        """The variable names of the variants stored under `key` (most recent first), locally
        and on the server."""
        found = variant_list(self.local.get_action(key.variants_address))
        remote = self.remote
        if remote is not None:
            from wsbuild.cache.http import CacheUnavailable  # lazy: off builds with no server

            try:
                more = variant_list(remote.get_action(key.variants_address))
            except CacheUnavailable as error:
                self._remote_off(str(error))
                more = []
            found += [names for names in more if names not in found]
        return found[:MAX_VARIANTS]

    def _package_record(self, key: CacheKey, record: ActionResult) -> bytes | None:
        """The entry's package record (its blob, locally or from the server, checked against
        its digest); None when it has none or it cannot be had."""
        if not record.record_digest or record.record_size > MAX_RECORD_BYTES:
            return None
        import io

        data: bytes | None = None
        blob = self.local.blob_path(record.record_digest)
        if blob is not None:
            try:
                data = blob.read_bytes()
            except OSError:
                data = None
        remote = self.remote
        if data is None and remote is not None:
            from wsbuild.cache.http import (
                CacheUnavailable, TruncatedDownload)  # lazy: off builds with no server

            buffer = io.BytesIO()
            try:
                if remote.fetch_blob(record.record_digest, buffer):
                    data = buffer.getvalue()
            except CacheUnavailable as error:
                self._remote_off(str(error))
            except TruncatedDownload:
                data = None
        if data is None:
            return None
        import hashlib

        if hashlib.sha256(data).hexdigest() != record.record_digest:
            self._refuse(key, "its package record does not match its digest", local=False,
                         digest=None)
            return None
        return data

    def restore(self, key: CacheKey, dest: Path, found: Found | None = None) -> Restored | None:
        """Unpack `key`'s entry (`found` by find(), else looked up now) into the empty
        directory `dest`; None on a miss or a refused entry (then `dest` may hold debris: the
        caller discards it)."""
        found = found or self.find(key)
        if found is None:
            return None
        record, from_local = found.record, found.from_local
        address = key.address
        remote = self.remote
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
                self._keep_package_record(record, found.package_record)
                self.local.put_action(address, record.encode())
                self._stored = True
        return Restored(source, record.digest, members)

    def _keep_package_record(self, record: ActionResult, package_record: bytes | None) -> None:
        """A downloaded entry's package record, into the local tier beside its archive."""
        if package_record is None or self.local.blob_path(record.record_digest) is not None:
            return
        temp = self.local.temp_file()
        temp.write_bytes(package_record)
        self.local.put_blob(record.record_digest, temp)

    def _download(self, key: CacheKey, record: ActionResult, remote: HttpCache) -> Path | None:
        from wsbuild.cache.http import (
            CacheUnavailable, TruncatedDownload)  # lazy: off builds with no server

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
    def store(self, key: CacheKey, root: Path, files: Iterable[str] | None = None, *,
              package_record: bytes = b"", background: bool = False,
              variables: tuple[str, ...] = ()) -> str | None:
        """Pack `root` (or `files` below it) as `key`'s entry, with the package record it was
        built with (`package_record`, JSON); None when stored (or queued: `background` packs
        on the cache's own thread, while the build goes on), else why not. Problems of
        background stores end up in `notes`."""
        if self.read_only:
            return "the cache is read-only for this run"
        if background:
            self._submit(("store", key, root, None if files is None else list(files),
                          package_record, variables))
            return None
        why_not, upload = self._store_now(key, root, files, package_record, variables)
        if upload is not None:
            self._submit(("upload", *upload))
        return why_not

    def _store_now(self, key: CacheKey, root: Path, files: Iterable[str] | None,
                   package_record: bytes = b"", variables: tuple[str, ...] = ()
                   ) -> tuple[str | None, tuple[object, ...] | None]:
        """Pack and store locally, its variant named in its key's variants document; (why not
        stored, what to upload: the blobs, the addresses, the action record, the key and the
        variables)."""
        import hashlib

        temp = self.local.temp_file()
        try:
            with open(temp, "wb") as out:
                digest, size = pack(root, out, files)
        except (RefusedEntry, OSError) as error:
            temp.unlink(missing_ok=True)
            return f"not cached: {error}", None
        blobs = [(digest, self.local.put_blob(digest, temp))]
        record_digest = ""
        if package_record:
            record_digest = hashlib.sha256(package_record).hexdigest()
            record_temp = self.local.temp_file()
            record_temp.write_bytes(package_record)
            blobs.append((record_digest, self.local.put_blob(record_digest, record_temp)))
        record = ActionResult(key.package, digest, size, record_digest,
                              len(package_record)).encode()
        for address in key.addresses:
            self.local.put_action(address, record)
        if key.variant:
            known = variant_list(self.local.get_action(key.variants_address))
            self.local.put_action(key.variants_address, with_variant(known, variables))
        with self._lock:
            self._stored = True
            upload = self._uploads_on
        return None, (blobs, key.addresses, record, key, variables) if upload else None

    def _submit(self, item: tuple[object, ...]) -> None:
        with self._lock:
            if self._worker is None:
                self._worker = threading.Thread(target=self._work, name="wsbuild-cache",
                                                daemon=True)
                self._worker.start()
        self._queue.put(item)

    def _work(self) -> None:
        """The cache's thread: background packing and uploads, in order."""
        while (item := self._queue.get()) is not None:
            started, cpu_started = time.perf_counter(), time.thread_time()
            self._work_on(item)
            self.background_seconds += time.perf_counter() - started
            self.background_cpu_seconds += time.thread_time() - cpu_started

    def _work_on(self, item: tuple[object, ...]) -> None:
        if item[0] == "store":
            _, key, root, files, package_record, variables = item
            why_not, upload = self._store_now(key, root, files,  # type: ignore[arg-type]
                                              package_record,  # type: ignore[arg-type]
                                              variables)  # type: ignore[arg-type]
            if why_not:
                self.notes.append(f"{key.package}: {why_not}")  # type: ignore[attr-defined]
            if upload is not None:
                self._upload(*upload)  # type: ignore[arg-type]
        else:
            self._upload(*item[1:])  # type: ignore[arg-type]

    def _upload(self, blobs: list[tuple[str, Path]], addresses: tuple[str, ...],
                record: bytes, key: CacheKey, variables: tuple[str, ...]) -> None:
        from wsbuild.cache.http import (
            CacheRejected, CacheUnavailable)  # lazy: off builds with no server

        remote = self.remote
        if remote is None or not self._uploads_on:
            return
        try:
            for digest, blob in blobs:
                if not remote.has_blob(digest):
                    remote.put_blob(digest, blob)
            for address in addresses:
                remote.put_action(address, record)
            if key.variant:  # a race with another uploader loses one variant: a miss, no more
                known = variant_list(remote.get_action(key.variants_address))
                remote.put_action(key.variants_address, with_variant(known, variables))
        except CacheRejected as error:
            self._uploads_off(str(error))
        except CacheUnavailable as error:
            self._remote_off(str(error))
        except OSError:
            pass  # evicted locally meanwhile by another run: nothing to upload

    def close(self, *, wait: bool = True) -> None:
        """Finish uploads (unless `wait` is False, e.g. after Ctrl-C) and evict old entries."""
        if self._worker is not None:
            self._queue.put(None)
            if wait:
                self._worker.join()
        if self.remote is not None:
            self.remote.close()
        if self._stored and wait:
            self.local.prune()


def unpack_file(path: Path, dest: Path) -> int:
    with open(path, "rb") as handle:
        return unpack(handle, dest)
