"""A package's record, build/<pkg>/.wsbuild/record.json: everything that decided its last
build's output, as its steps were observed to read it (observe/), written once when the build
(or a restore, or early cutoff) finished.

It holds:
- `own`: the package's own files by content digest (record/own_files.py);
- `outside`: what its steps read outside the package: files by content, listings by entries,
  searches by the entries they match, probes by what is at each path (record/outside.py),
  and `read_by`: which steps read each, and each own file, where no build system watches
  it (a build type redoes from there);
- `environment`: the variables its steps read, each by a digest of its value as the step
  would get it before its dependencies' hooks (what a plan compares), and
  `environment_seen`: the same variables as the steps saw them (what early cutoff compares
  after a dependency was rebuilt; record/environment.py); `environment_names` when a step
  listed the names;
- `installs_read`: the workspace packages whose install its steps read (a plan orders it
  after them, whether it declares them or not);
- `complete`: every process of every step was observed; when not (`unobserved` says why),
  the package runs its build system every time;
- `volatile`: why its build system had work left right after its build (an always-out-of-date
  target): it runs every time too;
- `settings`: the options that shape its output, the interpreter, the underlay's paths, the
  install prefix, wsbuild's version;
- `dependencies`: the keys (and inputs keys) of the workspace packages it was built against;
- `installed`: what it installed, by content and link target (record/installed.py).

Two keys derive from it. `inputs_key` digests what is known before a build reads anything
(own files, settings, the dependencies' inputs keys): the build cache finds candidate entries
by it, and an entry is restored only when this machine proves what the entry's record says
its steps read (cache/run.py). `key` adds what the steps read (outside files, the variables)
and the dependencies' keys: it is what dependents record and what a cached test result is
valid for.

Values of environment variables are never written, only digests; the directory and the file
are private to the user (0700, 0600)."""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from wsbuild import inputs
from wsbuild.hashes import blake2b
from wsbuild.files import atomic_write, private_directory
from wsbuild.record.installed import Installed
from wsbuild.record.outside import Looked, OutsideReads, Seen
from wsbuild.record.own_files import OwnFile, files_digest

#: where a package's record is, under its build directory
RECORD_FILE = Path(".wsbuild") / "record.json"
#: bumped whenever the record's shape or meaning changes: an older record reads as none
FORMAT = 2
#: what a package's key is in a plan until its build (or restore) in this run says it,
#: followed by its inputs key
PENDING = "pending:"


def digest_of(value: object) -> str:
    """A digest of a JSON value (keys sorted)."""
    return blake2b(json.dumps(value, sort_keys=True).encode(), digest_size=16).hexdigest()


@dataclass(frozen=True, slots=True)
class PackageRecord:
    """What a package's last build was made of and read: the record a no-op checks."""

    package: str
    build_type: str
    own: Mapping[str, OwnFile]
    settings: Mapping[str, object]
    #: the variables its steps read -> digest of the value before its dependencies' hooks
    environment: Mapping[str, str]
    #: the keys of its workspace dependencies it was built against
    dependencies: Mapping[str, str]
    #: and their inputs keys (what its own inputs key holds of them)
    dependency_inputs: Mapping[str, str] = field(default_factory=dict)
    outside: OutsideReads = field(default_factory=OutsideReads)
    #: every process of its steps was observed
    complete: bool = False
    installed: tuple[Installed, ...] = ()
    #: its tests run from what the build left in its build directory (TestRunner's
    #: `tests_in_build_tree`): after a restore, `wsbuild test` builds that tree first
    test_tree: bool = False
    #: the variables as its steps saw them (its dependencies' hooks applied)
    environment_seen: Mapping[str, str] = field(default_factory=dict)
    #: a digest of the set of variables' names, when a step listed them ("" when none did)
    environment_names: str = ""
    #: why its steps were not fully observed
    unobserved: tuple[str, ...] = ()
    #: why its build system still had work right after its build ("" when it had none)
    volatile: str = ""
    #: outside path, own file's name or `$NAME` -> the labels of the steps that read it,
    #: where no build system watches it (comma-separated)
    read_by: Mapping[str, str] = field(default_factory=dict)
    #: the workspace packages whose install its steps read (its declared dependencies or not:
    #: a plan starts it after them, record/undeclared.py)
    installs_read: tuple[str, ...] = ()
    #: the keys (see the module's docstring) and the own files' digest, computed by `sealed()`
    inputs_key: str = ""
    key: str = ""
    own_digest: str = ""

    def sealed(self) -> PackageRecord:
        """The record with its keys computed from its fields."""
        own = files_digest(self.own)
        before = inputs_key(self.package, self.build_type, own, self.settings,
                            self.dependency_inputs)
        return replace(self, inputs_key=before, own_digest=own,
                       key=output_key(before, self.outside, self.dependencies,
                                      self.environment, self.environment_names))


def inputs_key(package: str, build_type: str, own_digest: str, settings: Mapping[str, object],
               dependency_inputs: Mapping[str, str]) -> str:
    """What decides a package's output that is known before its build reads anything: its
    own files, settings and its dependencies' inputs keys."""
    return digest_of([package, build_type, own_digest, settings,
                      sorted(dependency_inputs.items())])


def output_key(inputs_key: str, outside: OutsideReads, dependencies: Mapping[str, str],
               environment: Mapping[str, str], environment_names: str = "") -> str:
    """`inputs_key` with what the build read outside the package, the variables it read and
    its dependencies' keys."""
    return digest_of([inputs_key, outside.digest(), sorted(dependencies.items()),
                      sorted(environment.items()), environment_names])


def record_path(build_dir: Path) -> Path:
    return build_dir / RECORD_FILE


def read_record(build_dir: Path) -> PackageRecord | None:
    """The package's record; None when there is none, or one this version cannot read. Taken
    from the build base's memo while its file is the one the memo holds (record/memo.py)."""
    from wsbuild.record.memo import memo_of  # lazy: off `list` and `graph`

    path = build_dir / RECORD_FILE
    signature = inputs.signature(path)
    if signature == inputs.ABSENT:
        return None
    memo = memo_of(build_dir.parent, FORMAT)
    held = memo.get(build_dir.name, signature)
    if held is not None:
        return decode(held[0], sealed=False, outside=held[1])
    try:
        data = json.loads(inputs.read_text(path))
    except (OSError, ValueError):
        return None
    record = decode(data, sealed=False)
    if record is not None and inputs.signature(path) == signature:
        memo.put(build_dir.name, signature, data, record.outside)
    return record


#: a record holds thousands of these: made without NamedTuple's checks (a malformed value
#: raises, and the record reads as none)
_new = tuple.__new__
_new_installed = functools.partial(_new, Installed)


class PackedReadBy(Mapping[str, str]):
    """A record's `read_by` as the memo keeps it (record/memo.py: compressed marshal data),
    unpacked at first use: only a package whose inputs changed asks which steps read them,
    and a no-op plan of many packages would otherwise unpack every record's paths."""

    __slots__ = ("_packed", "_read_by")

    def __init__(self, packed: bytes) -> None:
        self._packed = packed
        self._read_by: dict[str, str] | None = None

    def _unpacked(self) -> dict[str, str]:
        if self._read_by is None:
            import marshal
            import zlib

            value = marshal.loads(zlib.decompress(self._packed))
            self._read_by = {str(k): str(v) for k, v in value.items()}
        return self._read_by

    def __getitem__(self, path: str) -> str:
        return self._unpacked()[path]

    def __iter__(self):  # type: ignore[no-untyped-def]
        return iter(self._unpacked())

    def __len__(self) -> int:
        return len(self._unpacked())

    def __repr__(self) -> str:
        return repr(self._unpacked())


def _read_by(value: object) -> Mapping[str, str]:
    if type(value) is bytes:  # the memo's (its shape checked when unpacked)
        return PackedReadBy(value)
    return {str(k): str(v) for k, v in value.items()}  # type: ignore[attr-defined]


def _seen(value: object) -> Seen:
    signature, digest = value  # type: ignore[misc]
    if type(digest) is not str:
        raise TypeError("a digest is a string")
    return _new(Seen, (tuple(signature), digest))


def _looked(value: object) -> Looked:
    names, signature, digest = value  # type: ignore[misc]
    if type(digest) is not str or type(names) is not str:
        raise TypeError("a digest and names are strings")
    return _new(Looked, (tuple(names.split("/")) if names else (),
                         _new(Seen, (tuple(signature), digest))))


def encode_outside(outside: OutsideReads) -> dict[str, object]:
    """What was read outside, as JSON values."""
    return {
        "files": {p: [list(s.signature), s.digest] for p, s in sorted(outside.files.items())},
        "listings": {p: [list(s.signature), s.digest]
                     for p, s in sorted(outside.listings.items())},
        "searches": {p: ["/".join(n), list(s.signature), s.digest]
                     for p, (n, s) in sorted(outside.searches.items())},
        "probes": {p: ["/".join(n), list(s.signature), s.digest]
                   for p, (n, s) in sorted(outside.probes.items())},
    }


def decode_outside(data: Mapping[str, Mapping[str, object]]) -> OutsideReads:
    """What was read outside, from its JSON values (raises KeyError, TypeError, ValueError)."""
    return OutsideReads({p: _seen(v) for p, v in data["files"].items()},
                        {p: _seen(v) for p, v in data["listings"].items()},
                        {p: _looked(v) for p, v in data["searches"].items()},
                        {p: _looked(v) for p, v in data["probes"].items()})


def encode(record: PackageRecord) -> dict[str, object]:
    """The record as JSON values (also what a build cache entry carries)."""
    return {
        "format": FORMAT,
        "package": record.package,
        "build_type": record.build_type,
        "key": record.key,
        "inputs_key": record.inputs_key,
        "own_digest": record.own_digest,
        "own": {rel: value.as_list() for rel, value in sorted(record.own.items())},
        "settings": record.settings,
        "environment": dict(sorted(record.environment.items())),
        "environment_seen": dict(sorted(record.environment_seen.items())),
        "environment_names": record.environment_names,
        "dependencies": dict(sorted(record.dependencies.items())),
        "dependency_inputs": dict(sorted(record.dependency_inputs.items())),
        "outside": encode_outside(record.outside),
        "read_by": dict(sorted(record.read_by.items())),
        "installs_read": list(record.installs_read),
        "complete": record.complete,
        "unobserved": list(record.unobserved),
        "volatile": record.volatile,
        "installed": [[i.rel, list(i.signature), i.digest] for i in record.installed],
        "test_tree": record.test_tree,
    }


def _installed(entries: object) -> tuple[Installed, ...]:
    """A record's installed files from its JSON values; the memo's (record/memo.py) are
    tuples of their final types already, converted when the memo took them."""
    if type(entries) is tuple:
        return tuple(map(_new_installed, entries))
    return tuple(Installed(str(rel), tuple(int(x) for x in signature), str(digest))
                 for rel, signature, digest in entries)  # type: ignore[attr-defined]


def decode(data: object, *, sealed: bool = True,
           outside: OutsideReads | None = None) -> PackageRecord | None:
    """A record from its JSON values; None when it is not one. `sealed`: its keys computed
    here (a build cache entry's: never taken from the data), else the ones it carries (the
    package's own record, written by `write_record`). `outside`: its outside reads, decoded
    already (the memo's)."""
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        return None
    try:
        record = PackageRecord(
            package=str(data["package"]),
            build_type=str(data["build_type"]),
            own={str(rel): OwnFile(*value) for rel, value in data["own"].items()},
            settings=dict(data["settings"]),
            environment={str(k): str(v) for k, v in data["environment"].items()},
            environment_seen={str(k): str(v) for k, v in data["environment_seen"].items()},
            environment_names=str(data["environment_names"]),
            dependencies={str(k): str(v) for k, v in data["dependencies"].items()},
            dependency_inputs={str(k): str(v) for k, v in data["dependency_inputs"].items()},
            outside=outside if outside is not None else decode_outside(data["outside"]),
            read_by=_read_by(data["read_by"]),
            installs_read=tuple(str(name) for name in data["installs_read"]),
            complete=bool(data["complete"]),
            unobserved=tuple(str(why) for why in data["unobserved"]),
            volatile=str(data["volatile"]),
            installed=_installed(data["installed"]),
            test_tree=bool(data["test_tree"]),
        )
        if sealed:
            return record.sealed()
        return replace(record, inputs_key=str(data["inputs_key"]), key=str(data["key"]),
                       own_digest=str(data["own_digest"]))
    except (KeyError, TypeError, ValueError, AttributeError):
        return None


def write_record(build_dir: Path, record: PackageRecord) -> None:
    """Write the record, its keys computed (its directory 0700, the file 0600)."""
    from wsbuild.record.memo import memo_of  # lazy: off `list` and `graph`

    record = record.sealed()
    directory = private_directory(build_dir / RECORD_FILE.parent)
    text = json.dumps(encode(record), separators=(",", ":"))
    atomic_write(directory / RECORD_FILE.name, text, mode=0o600)
    signature = inputs.signature(directory / RECORD_FILE.name)
    # the memo holds the values as the file gives them back (JSON has no tuples)
    memo_of(build_dir.parent, FORMAT).put(build_dir.name, signature, json.loads(text),
                                          record.outside)
