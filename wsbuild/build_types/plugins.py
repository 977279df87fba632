"""The extensions other distributions install, found by their entry points: build types
(group `wsbuild.build_types`) and package identifiers (`wsbuild.package_identification`: a
way to recognise a package directory that has no package.xml).

Scanning the installed distributions costs a run tens of milliseconds (importlib.metadata,
then every dist-info of the interpreter's path), and every load of a workspace asks for the
identifiers. What one scan found is kept in the user's cache (`wsbuild-observe/plugins/<digest
of the interpreter and its path>.json`, readable by its owner only) with the path it scanned and the stat signature of each of the path's
directories, which changes with every distribution installed or removed there; while they hold,
the scan's answer is taken from it. Those signatures are the declared inputs
(wsbuild/inputs.py) of whatever the answer decides."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from wsbuild import inputs
from wsbuild.errors import WsbuildError
from wsbuild.files import atomic_write, private_directory, user_cache_dir

BUILD_TYPES = "wsbuild.build_types"
PACKAGE_IDENTIFICATION = "wsbuild.package_identification"
GROUPS = (BUILD_TYPES, PACKAGE_IDENTIFICATION)
_FORMAT = 1


@dataclass(frozen=True, slots=True)
class Entry:
    """One entry point: its name in its group, and the `module:attribute` it names."""

    group: str
    name: str
    value: str

    def load(self) -> object:
        return load_value(self.value)


def load_value(value: str) -> object:
    """What `module:attribute` names, loaded as importlib.metadata.EntryPoint.load() does
    (without importing importlib.metadata, which a no-op build need not pay for): the
    built-in build types' entry points and the plugins'."""
    import importlib

    module, _, attribute = value.partition(":")
    loaded: object = importlib.import_module(module)
    for part in attribute.split(".") if attribute else ():
        loaded = getattr(loaded, part)
    return loaded


_found: dict[str, tuple[Entry, ...]] = {}


def entries(group: str) -> tuple[Entry, ...]:
    """The entry points of `group` the installed distributions register (by name)."""
    if not _found:
        _found.update(_scanned())
    return _found.get(group, ())


def _scanned_path() -> list[str]:
    """The interpreter's path but its first entry: the directory of the script or, with
    `python -m`, the working directory (a workspace, not where distributions are installed)."""
    return [entry for entry in sys.path[1:] if entry]


def _path_signatures() -> list[list[object]]:
    """The scanned path and each directory's signature (declared: a distribution installed or
    removed changes its directory's)."""
    return [[entry, list(inputs.signature(entry))] for entry in _scanned_path()]


def _memo_file() -> Path:
    """One memo for each interpreter and path (runs with another PYTHONPATH keep theirs),
    beside the file digests' memo (record/file_digests.py): never in the build cache's
    directory, which `--no-cache` leaves untouched."""
    from wsbuild.record.model import digest_of  # lazy: off `test-result` and `report`

    return user_cache_dir(os.environ, "wsbuild-observe") / "plugins" / \
        f"{digest_of([sys.executable, _scanned_path()])}.json"


def _scanned() -> dict[str, tuple[Entry, ...]]:
    key = {"format": _FORMAT, "python": sys.executable, "path": _path_signatures()}
    memo = _memo_file()
    inputs.declare_memo(memo)
    try:
        kept = json.loads(memo.read_text(encoding="utf-8"))
        if kept.get("key") == key:
            return {group: tuple(Entry(group, str(n), str(v)) for n, v in kept["entries"][group])
                    for group in GROUPS}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        pass
    found = _scan()
    try:
        private_directory(memo.parent)
        atomic_write(memo, json.dumps({"key": key, "entries": {
            group: [[e.name, e.value] for e in found[group]] for group in GROUPS}}) + "\n",
            mode=0o600)
    except OSError:
        pass  # a read-only cache: the next run scans again
    return found


def _scan() -> dict[str, tuple[Entry, ...]]:
    """Every distribution's entry points of the groups (the first of a name, in the path's
    order, as importlib.metadata gives them), each distribution's file declared."""
    from importlib.metadata import distributions

    found: dict[str, dict[str, Entry]] = {group: {} for group in GROUPS}
    for dist in distributions(path=_scanned_path()):
        where = getattr(dist, "_path", None)
        if where is not None:
            inputs.declare_file(Path(where) / "entry_points.txt")
        for ep in dist.entry_points:
            if ep.group in found:
                found[ep.group].setdefault(ep.name, Entry(ep.group, ep.name, ep.value))
    return {group: tuple(sorted(entries.values(), key=lambda e: e.name))
            for group, entries in found.items()}

def package_identifiers() -> list[Callable[[Path, frozenset[str]], object]]:
    """The installed package identifiers (workspace/discover.py's `Identifier`), by name; one
    that cannot be loaded, or is not callable, is an error naming it."""
    loaded = []
    for entry in entries(PACKAGE_IDENTIFICATION):
        try:
            identifier = entry.load()
        except Exception as exc:  # a broken plugin fails loudly, naming itself
            raise WsbuildError(
                f"package identifier '{entry.name}' ({entry.value}, entry point group "
                f"{PACKAGE_IDENTIFICATION}) cannot be loaded: {exc}",
                hint="update or uninstall the distribution that provides it") from None
        if not callable(identifier):
            raise WsbuildError(
                f"package identifier '{entry.name}' ({entry.value}) is not callable",
                hint="it names a function (directory, names) -> Package | None")
        loaded.append(identifier)
    return loaded
