"""The action-cache record: which archive holds a cache key's install.

It is the JSON form of the Remote Execution API's ActionResult (one output file: the archive),
so bazel-remote accepts it with `Content-Type: application/json` and hands it back as JSON;
a plain WebDAV server (nginx) stores and returns the bytes as they are.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass

from wsbuild.cache.key import is_digest

_PATH = re.compile(r"wsbuild/([A-Za-z0-9_.-]+)\.tar\.zst")


@dataclass(frozen=True, slots=True)
class ActionResult:
    package: str
    digest: str
    size: int

    def encode(self) -> bytes:
        data = {"outputFiles": [{
            "path": f"wsbuild/{self.package}.tar.zst",
            "digest": {"hash": self.digest, "sizeBytes": str(self.size)},
        }]}
        return json.dumps(data, sort_keys=True).encode()


def parse_action_result(data: bytes) -> ActionResult | None:
    """The record in `data`, or None when it is anything else (a miss, never an error)."""
    try:
        value = json.loads(data)
        files = value.get("outputFiles", value.get("output_files"))
        entry = files[0]
        match = _PATH.fullmatch(entry["path"])
        digest = entry["digest"]
        hash_ = digest["hash"]
        size = int(digest.get("sizeBytes", digest.get("size_bytes")))
    except (ValueError, TypeError, KeyError, IndexError, AttributeError):
        return None
    if match is None or not isinstance(hash_, str) or not is_digest(hash_) or size <= 0:
        return None
    return ActionResult(match.group(1), hash_, size)
