"""The records of a build base's packages in one file, `build/.wsbuild/records.memo`, so that a
plan reads them at once: derived from each package's `record.json` and never instead of it.

A record is taken from the memo only while its `record.json` has the stat signature the memo
noted with it (a build writes a new file: another inode, another signature); otherwise it is
read from its file and the memo notes it anew. What many records read outside (the
interpreter's modules, the system's headers, CMake's modules) is held once in the memo and
shared by the records in memory, where each `record.json` holds its own copy (it stands alone:
a build cache entry carries it).

The memo is written when a run that is not a dry run ends and a record was read from its file
or written (record/model.py's `write_record` notes the new one). It is marshal data of this
interpreter's version, private to the user (0600); one of another version, or unreadable, is
no memo."""

from __future__ import annotations

import marshal
import os
import sys
import threading
import zlib
from operator import itemgetter
from pathlib import Path

from wsbuild import inputs
from wsbuild.files import atomic_write, private_directory
from wsbuild.record.outside import HeldEntries, Looked, OutsideReads, Seen, SharedEntries

#: under the build base
MEMO_FILE = Path(".wsbuild") / "records.memo"
#: bumped whenever the memo's shape changes
_VERSION = 4
_new = tuple.__new__
_KINDS = ("files", "listings", "searches", "probes")
#: a record's values that are often equal to another record's
_SHARED_VALUES = ("environment", "environment_seen", "settings", "dependencies",
                  "dependency_inputs", "unobserved", "installs_read")

_lock = threading.Lock()
_memos: dict[str, RecordsMemo] = {}


class RecordsMemo:
    """One build base's memo, loaded once per process."""

    def __init__(self, path: Path, record_format: int) -> None:
        self.path = path
        self.header = [_VERSION, record_format, sys.version]
        #: package -> (record.json's signature, the record's JSON values but its outside
        #: reads, those as (path, seen) pairs of each kind, and as entries of `table` when
        #: loaded from the file)
        self._records: dict[str, tuple[tuple[int, ...], dict[str, object],
                                       tuple[tuple[tuple[str, Seen | Looked], ...], ...],
                                       HeldEntries | None]] = {}
        #: the outside reads of the records loaded, each once
        self.table = SharedEntries(())
        self.changed = False
        self._load()

    def _load(self) -> None:
        inputs.declare_memo(self.path)  # each record it answers is checked by its file's stat
        try:
            with open(self.path, "rb") as handle:
                data = marshal.loads(handle.read())
        except (OSError, EOFError, ValueError, TypeError):
            return
        try:
            if not isinstance(data, dict) or data.get("format") != self.header:
                return
            shared = [_entry(*value) for value in data["entries"]]
            self.table = SharedEntries(shared)
            for name, (signature, values, ids) in data["records"].items():
                self._records[name] = (tuple(signature), values, tuple(
                    _gather(shared, kind) for kind in ids), HeldEntries(self.table, tuple(ids)))
        except (KeyError, TypeError, ValueError, IndexError):
            self._records.clear()

    def get(self, package: str, signature: tuple[int, ...]
            ) -> tuple[dict[str, object], OutsideReads] | None:
        """The record's JSON values (but its outside reads) and its outside reads, when the
        memo holds the record of the file with `signature`."""
        with _lock:
            held = self._records.get(package)
        if held is None or held[0] != signature or signature == inputs.ABSENT:
            return None
        _, values, kinds, entries = held
        return values, OutsideReads(*(dict(kind) for kind in kinds), held=entries)

    def put(self, package: str, signature: tuple[int, ...], values: dict[str, object],
            outside: OutsideReads) -> None:
        """Note the record read from (or just written to) the file with `signature`."""
        kept = {k: v for k, v in values.items() if k != "outside"}
        # the installed files as a record holds them (decoded without a conversion per file)
        kept["installed"] = tuple((str(rel), tuple(int(x) for x in seen), str(digest))
                                  for rel, seen, digest in values["installed"])
        if isinstance(kept.get("read_by"), dict):  # unpacked only when asked (PackedReadBy)
            kept["read_by"] = zlib.compress(marshal.dumps(kept["read_by"]), 1)
        kinds = tuple(tuple(getattr(outside, kind).items()) for kind in _KINDS)
        with _lock:
            self._records[package] = (signature, kept, kinds, None)
            self.changed = True

    def save(self) -> None:
        """Write the memo when it changed (the outside reads each held once)."""
        with _lock:
            if not self.changed:
                return
            index: dict[tuple[str, Seen | Looked], int] = {}
            entries: list[tuple[object, ...]] = []
            records = {}
            # equal values of several records written once (marshal keeps one object and
            # refers to it): most packages read the same variables
            alike: dict[tuple[str, str], object] = {}
            for name, (signature, values, kinds, _) in sorted(self._records.items()):
                values = dict(values)
                for key in _SHARED_VALUES:
                    if key in values:
                        values[key] = alike.setdefault((key, repr(values[key])), values[key])
                ids = []
                for kind in kinds:
                    found = []
                    for pair in kind:
                        at = index.get(pair)
                        if at is None:
                            at = index[pair] = len(entries)
                            entries.append(_flat(*pair))
                        found.append(at)
                    ids.append(found)
                records[name] = (list(signature), values, ids)
            self.changed = False
        data = marshal.dumps({"format": self.header, "entries": entries, "records": records})
        try:
            private_directory(self.path.parent)
            atomic_write(self.path, data, mode=0o600)
        except OSError:
            pass  # a memo is never worth failing the run: the next plan reads the files


def _gather(shared: list[tuple[str, Seen | Looked]], ids: list[int]
            ) -> tuple[tuple[str, Seen | Looked], ...]:
    """The entries `ids` of `shared` (in one call: a plan gathers tens of thousands)."""
    if len(ids) > 1:
        return itemgetter(*ids)(shared)  # type: ignore[no-any-return]
    return tuple(shared[i] for i in ids)


def _flat(path: str, seen: Seen | Looked) -> tuple[object, ...]:
    if isinstance(seen, Looked):
        return (path, list(seen.seen.signature), seen.seen.digest, "/".join(seen.names))
    return (path, list(seen.signature), seen.digest, None)


def _entry(path: str, signature: list[int], digest: str, names: str | None
           ) -> tuple[str, Seen | Looked]:
    seen = _new(Seen, (tuple(signature), digest))
    if names is None:
        return path, seen
    return path, _new(Looked, (tuple(names.split("/")) if names else (), seen))


def memo_of(build_base: Path, record_format: int) -> RecordsMemo:
    """The memo of `build_base`, loaded at first use in this process."""
    key = os.path.abspath(build_base)
    with _lock:
        memo = _memos.get(key)
    if memo is None:
        loaded = RecordsMemo(Path(key) / MEMO_FILE, record_format)
        with _lock:
            memo = _memos.setdefault(key, loaded)
    return memo


def save_memos() -> None:
    """Write every memo this process changed (at the end of a run that is not a dry run)."""
    with _lock:
        memos = list(_memos.values())
    for memo in memos:
        memo.save()
