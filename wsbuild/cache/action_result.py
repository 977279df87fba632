"""The action-cache record: which archive holds a cache key's install, and which blob holds the
package record it was built with.

It is the JSON form of the Remote Execution API's ActionResult (two output files: the archive
and the package record, both in the CAS), so bazel-remote accepts it with
`Content-Type: application/json` and hands it back as JSON; a plain WebDAV server (nginx)
stores and returns the bytes as they are.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

from wsbuild.cache.key import is_digest
from wsbuild.patterns import lazy

_ARCHIVE = lazy(r"wsbuild/([A-Za-z0-9_.-]+)\.tar\.zst")
_RECORD = lazy(r"wsbuild/([A-Za-z0-9_.-]+)\.record\.json")


@dataclass(frozen=True, slots=True)
class ActionResult:
    """A cache entry's description: the package, its archive's digest and size, its record."""

    package: str
    digest: str
    size: int
    #: the package record's blob (record/model.py's JSON): what the entry was built from and
    #: what its build read outside the package ("" for an entry without one: never restored)
    record_digest: str = ""
    record_size: int = 0

    def encode(self) -> bytes:
        files = [{
            "path": f"wsbuild/{self.package}.tar.zst",
            "digest": {"hash": self.digest, "sizeBytes": str(self.size)},
        }]
        if self.record_digest:
            files.append({
                "path": f"wsbuild/{self.package}.record.json",
                "digest": {"hash": self.record_digest, "sizeBytes": str(self.record_size)},
            })
        return json.dumps({"outputFiles": files}, sort_keys=True).encode()


def _file(entry: object) -> tuple[str, str, int] | None:
    """(path, hash, size) of one output file, None when it is not one."""
    try:
        digest = entry["digest"]  # type: ignore[index]
        hash_ = digest["hash"]
        size = int(digest.get("sizeBytes", digest.get("size_bytes")))
        path = entry["path"]  # type: ignore[index]
    except (ValueError, TypeError, KeyError, AttributeError):
        return None
    if not isinstance(hash_, str) or not is_digest(hash_) or size <= 0 or not isinstance(path, str):
        return None
    return path, hash_, size


def parse_action_result(data: bytes) -> ActionResult | None:
    """The record in `data`, or None when it is anything else (a miss, never an error)."""
    try:
        value = json.loads(data)
        files = value.get("outputFiles", value.get("output_files"))
        found = [_file(entry) for entry in files]
    except (ValueError, TypeError, AttributeError):
        return None
    archive = record = None
    for item in found:
        if item is None:
            return None
        path, hash_, size = item
        if (match := _ARCHIVE.fullmatch(path)) is not None and archive is None:
            archive = (match.group(1), hash_, size)
        elif (match := _RECORD.fullmatch(path)) is not None and record is None:
            record = (match.group(1), hash_, size)
        else:
            return None
    if archive is None or (record is not None and record[0] != archive[0]):
        return None
    return ActionResult(archive[0], archive[1], archive[2],
                        record[1] if record else "", record[2] if record else 0)
