"""Small JSON documents the jobs of a CI matrix share through the cache server, beside the
build cache's entries: the packages' recorded build times the split is balanced on, and what
each shard of a run planned (builder/shards/run.py).

A document is a blob in the CAS and an action record naming it (`wsbuild/<kind>.json`), at
the address sha256("wsbuild document <name>"): the layout bazel-remote and nginx (WebDAV)
already serve. It is replaced whole by whoever writes last. Never trusted beyond its shape:
a document that is not the JSON object it should be reads as none; one that cannot be read or
written costs one line in `problems`, never the build.
"""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path

from wsbuild.cache.http import CacheRejected, CacheUnavailable, HttpCache, TruncatedDownload
from wsbuild.cache.key import is_digest
from wsbuild.cache.settings import CacheSettings
from wsbuild.patterns import lazy

#: bumped whenever a document's layout changes: older ones then read as none
FORMAT = 1
#: the largest document read (a split of thousands of packages is a few hundred KiB)
MAX_BYTES = 16 * 1024 * 1024
_PATH = lazy(r"wsbuild/document-([a-z]+)\.json")


def document_address(name: str) -> str:
    return hashlib.sha256(f"wsbuild document {FORMAT} {name}".encode()).hexdigest()


class SharedDocuments:
    """The documents on one cache server."""

    def __init__(self, server: HttpCache) -> None:
        self.server = server
        #: what could not be read or written (one line each)
        self.problems: list[str] = []

    @classmethod
    def open(cls, settings: CacheSettings | None) -> SharedDocuments | None:
        """The documents of the server `settings` name; None without one."""
        if settings is None or not settings.enabled or not settings.url:
            return None
        return cls(HttpCache(settings.url, timeout=settings.timeout))

    def get(self, name: str) -> dict[str, object] | None:
        """The document `name`, None when there is none (or it is not a JSON object)."""
        try:
            record = self.server.get_action(document_address(name))
            if record is None:
                return None
            blob = _blob_of(record)
            if blob is None:
                return None
            out = io.BytesIO()
            if not self.server.fetch_blob(blob, out) or len(out.getvalue()) > MAX_BYTES:
                return None
            data = out.getvalue()
        except (CacheUnavailable, TruncatedDownload) as error:
            self.problems.append(f"could not read {name}: {error}")
            return None
        if hashlib.sha256(data).hexdigest() != blob:
            return None
        try:
            value = json.loads(data)
        except ValueError:
            return None
        if not isinstance(value, dict) or value.get("format") != FORMAT:
            return None
        return value

    def put(self, name: str, value: dict[str, object], kind: str, scratch: Path) -> bool:
        """Write the document `name` (`kind` names what it is in its record); `scratch`: a
        directory for the blob's temporary file. False (and a line in `problems`) when the
        server would not take it."""
        data = json.dumps({**value, "format": FORMAT}, sort_keys=True,
                          separators=(",", ":")).encode()
        blob = hashlib.sha256(data).hexdigest()
        record = json.dumps({"outputFiles": [{
            "path": f"wsbuild/document-{kind}.json",
            "digest": {"hash": blob, "sizeBytes": str(len(data))}}]}, sort_keys=True).encode()
        scratch.mkdir(parents=True, exist_ok=True)
        temp = scratch / f"document-{blob}.json"
        try:
            temp.write_bytes(data)
            if not self.server.has_blob(blob):
                self.server.put_blob(blob, temp)
            self.server.put_action(document_address(name), record)
        except (CacheUnavailable, CacheRejected, OSError) as error:
            self.problems.append(f"could not write {name}: {error}")
            return False
        finally:
            temp.unlink(missing_ok=True)
        return True

    def close(self) -> None:
        self.server.close()


def _blob_of(record: bytes) -> str | None:
    """The digest of the one blob a document's record names; None for anything else."""
    try:
        files = json.loads(record)["outputFiles"]
        (entry,) = files
        path, hash_ = entry["path"], entry["digest"]["hash"]
    except (ValueError, TypeError, KeyError):
        return None
    if not isinstance(path, str) or not _PATH.fullmatch(path) or not isinstance(hash_, str) \
            or not is_digest(hash_):
        return None
    return hash_
