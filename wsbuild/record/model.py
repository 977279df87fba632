"""A package's record, build/<pkg>/.wsbuild/record.json: everything that decided its last
build's output, written once when the build (or a restore) finished.

It holds:
- `own`: the package's own files by content digest (record/own_files.py);
- `outside`: what its build read outside the package, files by content and directory listings
  by entries (record/outside.py), and whether that list is `complete` (the build system said
  what it read: a rebuilt dependency then matters only through it, early cutoff);
- `environment`: a digest of every variable that can reach a build (record/environment.py);
- `settings`: the options that shape its output, the interpreter, the underlay's paths, the
  install prefix, wsbuild's version;
- `dependencies`: the keys (and inputs keys) of the workspace packages it was built against;
- `installed`: the files it installed, with their sizes.

Two keys derive from it. `inputs_key` digests what is known before a build reads anything
(own files, settings, the environment but its `SHARED` variables, the dependencies' inputs
keys): the build cache finds entries by it. `key` adds what the build read outside and the
dependencies' keys: it is what dependents record and what a cached test result is valid for.

Values of environment variables are never written, only digests; the directory and the file
are private to the user (0700, 0600)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from wsbuild import inputs
from wsbuild.files import atomic_write, private_directory
from wsbuild.record.environment import keyed
from wsbuild.record.outside import OutsideReads, Seen
from wsbuild.record.own_files import OwnFile, files_digest

#: where a package's record is, under its build directory
RECORD_FILE = Path(".wsbuild") / "record.json"
#: bumped whenever the record's shape or meaning changes: an older record reads as none
FORMAT = 1
#: what a package's key is in a plan until its build (or restore) in this run says it,
#: followed by its inputs key
PENDING = "pending:"


def digest_of(value: object) -> str:
    """A digest of a JSON value (keys sorted)."""
    return hashlib.blake2b(json.dumps(value, sort_keys=True).encode(), digest_size=16).hexdigest()


@dataclass(frozen=True, slots=True)
class PackageRecord:
    package: str
    build_type: str
    own: Mapping[str, OwnFile]
    settings: Mapping[str, object]
    environment: Mapping[str, str]
    #: the keys of its workspace dependencies it was built against
    dependencies: Mapping[str, str]
    #: and their inputs keys (what its own inputs key holds of them)
    dependency_inputs: Mapping[str, str] = field(default_factory=dict)
    outside: OutsideReads = field(default_factory=OutsideReads)
    #: the build system said all it read outside (early cutoff may skip a rebuild)
    complete: bool = False
    installed: tuple[tuple[str, int], ...] = ()
    #: its tests run from what the build left in its build directory (TestRunner's
    #: `tests_in_build_tree`): after a restore, `wsbuild test` builds that tree first
    test_tree: bool = False
    #: the keys (see the module's docstring) and the own files' digest, computed by `sealed()`
    inputs_key: str = ""
    key: str = ""
    own_digest: str = ""

    def sealed(self) -> PackageRecord:
        """The record with its keys computed from its fields."""
        own = files_digest(self.own)
        before = inputs_key(self.package, self.build_type, own, self.settings,
                            self.environment, self.dependency_inputs)
        return replace(self, inputs_key=before, own_digest=own,
                       key=output_key(before, self.outside, self.dependencies))


def inputs_key(package: str, build_type: str, own_digest: str, settings: Mapping[str, object],
               environment: Mapping[str, str], dependency_inputs: Mapping[str, str]) -> str:
    """What decides a package's output that is known before its build reads anything: its
    own files, settings, environment (but the `SHARED` variables) and its dependencies'
    inputs keys."""
    return digest_of([package, build_type, own_digest, settings, keyed(environment),
                      sorted(dependency_inputs.items())])


def output_key(inputs_key: str, outside: OutsideReads, dependencies: Mapping[str, str]) -> str:
    """`inputs_key` with what the build read outside the package and its dependencies' keys."""
    return digest_of([inputs_key, outside.digest(), sorted(dependencies.items())])


def record_path(build_dir: Path) -> Path:
    return build_dir / RECORD_FILE


def read_record(build_dir: Path) -> PackageRecord | None:
    """The package's record; None when there is none, or one this version cannot read."""
    try:
        data = json.loads(inputs.read_text(build_dir / RECORD_FILE))
        if data["format"] != FORMAT:
            return None
        outside = data["outside"]
        return PackageRecord(
            package=data["package"],
            build_type=data["build_type"],
            own={rel: OwnFile(*value) for rel, value in data["own"].items()},
            settings=dict(data["settings"]),
            environment=dict(data["environment"]),
            dependencies=dict(data["dependencies"]),
            dependency_inputs=dict(data["dependency_inputs"]),
            outside=OutsideReads(
                {path: Seen(tuple(sig), digest) for path, (sig, digest) in outside["files"].items()},
                {path: Seen(tuple(sig), digest)
                 for path, (sig, digest) in outside["listings"].items()}),
            complete=bool(data["complete"]),
            installed=tuple((rel, size) for rel, size in data["installed"]),
            test_tree=bool(data["test_tree"]),
            inputs_key=data["inputs_key"],
            key=data["key"],
            own_digest=data["own_digest"],
        )
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


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
        "dependencies": dict(sorted(record.dependencies.items())),
        "dependency_inputs": dict(sorted(record.dependency_inputs.items())),
        "outside": {
            "files": {p: [list(s.signature), s.digest] for p, s in sorted(record.outside.files.items())},
            "listings": {p: [list(s.signature), s.digest]
                         for p, s in sorted(record.outside.listings.items())},
        },
        "complete": record.complete,
        "installed": [list(item) for item in record.installed],
        "test_tree": record.test_tree,
    }


def decode(data: object) -> PackageRecord | None:
    """A record from its JSON values (a build cache entry's), its keys computed here (never
    taken from the data); None when it is not one."""
    if not isinstance(data, dict):
        return None
    try:
        outside = data["outside"]
        return PackageRecord(
            package=str(data["package"]),
            build_type=str(data["build_type"]),
            own={str(rel): OwnFile(*value) for rel, value in data["own"].items()},
            settings=dict(data["settings"]),
            environment={str(k): str(v) for k, v in data["environment"].items()},
            dependencies={str(k): str(v) for k, v in data["dependencies"].items()},
            dependency_inputs={str(k): str(v) for k, v in data["dependency_inputs"].items()},
            outside=OutsideReads(
                {str(p): Seen(tuple(int(x) for x in sig), str(d))
                 for p, (sig, d) in outside["files"].items()},
                {str(p): Seen(tuple(int(x) for x in sig), str(d))
                 for p, (sig, d) in outside["listings"].items()}),
            complete=bool(data["complete"]),
            installed=tuple((str(rel), int(size)) for rel, size in data["installed"]),
            test_tree=bool(data["test_tree"]),
        ).sealed() if data.get("format") == FORMAT else None
    except (KeyError, TypeError, ValueError, AttributeError):
        return None


def write_record(build_dir: Path, record: PackageRecord) -> None:
    """Write the record, its keys computed (its directory 0700, the file 0600)."""
    record = record.sealed()
    directory = private_directory(build_dir / RECORD_FILE.parent)
    atomic_write(directory / RECORD_FILE.name,
                 json.dumps(encode(record), separators=(",", ":")), mode=0o600)
