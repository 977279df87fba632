"""What a package's build read outside the package, as its steps were observed to read it
(observe/): files by content digest, directory listings by their entries, directories searched
for some names only by the entries those names match (Python's import system looking a module
up, site.py looking for `.pth` files), and the paths its steps looked at or looked for, by
whether each is there and of which type (a header found in the second of two include
directories stays found there only while the first lacks it).

Each is held with the stat signature it had when its digest was taken: a check stats it and
takes the digest again only when the signature differs (a dependency reinstalled to the same
bytes, a file copied onto another machine), so an unchanged input costs one stat. Digests are
kept for the process (`Digests`): packages share most of what they read outside (the
compiler's headers, CMake's modules, setuptools), and each is read once per run."""

from __future__ import annotations

import functools
import os
import stat as modes
import threading
import time
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

from wsbuild import inputs
from wsbuild.hashes import blake2b
from wsbuild.files import STAGE_DIR, TEMP_SUFFIX
from wsbuild.record.own_files import content_digest

if TYPE_CHECKING:
    from wsbuild.record.file_digests import FileDigests

#: the digest of a path that does not exist, of a directory read as a file, of a file that
#: changed while the build ran (never equal to a digest taken later: the next check builds)
ABSENT_DIGEST, DIRECTORY_DIGEST, RACY_DIGEST = "", "directory", "racy"

#: the entries of a listed directory that the package itself installs there (no input of its
#: own build: in a merged install, install/'s directories hold every package's files)
OwnEntries = Callable[[str], frozenset[str]]


def no_own_entries(_path: str) -> frozenset[str]:
    return frozenset()


def own_entries(install_base: str, installed: Collection[Sequence[object]], *,
                package: str = "", keep: Collection[str] = ()) -> OwnEntries:
    """The names a package's installed files (relative to `install_base`) put into each
    directory: what a listing of that directory leaves out; in a merged install also what
    the workspace's packages but `package` and its dependencies (`keep`) put there
    (record/merged_owners.py)."""
    from wsbuild.record.merged_owners import others_in  # lazy: off `list` and `graph`

    base = install_base.rstrip(os.sep) + os.sep
    files = [str(entry[0]) for entry in installed]

    def entries(path: str) -> frozenset[str]:
        if not (path + os.sep).startswith(base):
            return frozenset()
        rel = path[len(base):].strip(os.sep)
        prefix = rel + os.sep if rel else ""
        own = frozenset(f[len(prefix):].split(os.sep, 1)[0] for f in files
                        if f.startswith(prefix) and len(f) > len(prefix))
        return own | others_in(install_base, rel, package, keep)

    return entries


class Seen(NamedTuple):
    """A path as the record holds it: its stat signature, and its content's digest (a file) or
    its entries' (a listing, a search, the probes of its names)."""

    signature: tuple[int, ...]
    digest: str


class Looked(NamedTuple):
    """A directory looked into for some names only: the names (fnmatch patterns for a search,
    plain names for probes, sorted) and what was seen of them."""

    names: tuple[str, ...]
    seen: Seen


class SharedEntries:
    """The outside reads several records hold, each once (record/memo.py's table): a plan
    looks at each entry once, not once per record that holds it (`Digests.entries_changed`)."""

    __slots__ = ("pairs",)

    def __init__(self, pairs: Sequence[tuple[str, Seen | Looked]]) -> None:
        self.pairs = pairs


@dataclass(frozen=True, slots=True)
class HeldEntries:
    """Which entries of a `SharedEntries` a record's outside reads are (all of them)."""

    table: SharedEntries
    ids: tuple[Sequence[int], ...]


@dataclass(frozen=True, slots=True)
class OutsideReads:
    """What the package's build read outside the package (absolute paths): files, listings,
    searches (directory -> the patterns of the names looked up) and probes (directory -> the
    names looked at or for in it)."""

    files: Mapping[str, Seen] = field(default_factory=dict)
    listings: Mapping[str, Seen] = field(default_factory=dict)
    searches: Mapping[str, Looked] = field(default_factory=dict)
    probes: Mapping[str, Looked] = field(default_factory=dict)
    #: the same reads as entries of the memo's table, when they came from it (not compared;
    #: set by record/memo.py only: reads are never changed in place nor `replace`d)
    held: HeldEntries | None = field(default=None, compare=False, repr=False)

    def digest(self) -> str:
        """One digest of every path with its content's (or entries') digest."""
        total = blake2b(digest_size=16)
        for kind, seen in (("f", self.files), ("l", self.listings)):
            for path in sorted(seen):
                total.update(f"{kind}\0{path}\0{seen[path].digest}\n"
                             .encode("utf-8", "surrogateescape"))
        for kind, looked in (("s", self.searches), ("p", self.probes)):
            for path in sorted(looked):
                names, seen = looked[path]
                total.update(f"{kind}\0{path}\0{'/'.join(names)}\0{seen.digest}\n"
                             .encode("utf-8", "surrogateescape"))
        return total.hexdigest()

    def __len__(self) -> int:
        return len(self.files) + len(self.listings) + len(self.searches) + len(self.probes)

    def paths(self) -> Iterator[str]:
        """Every file and directory it names (probes as the paths they looked at)."""
        yield from self.files
        yield from self.listings
        yield from self.searches
        for directory, (names, _) in self.probes.items():
            yield from (f"{directory}/{name}" if directory != "/" else f"/{name}"
                        for name in names)


class Digests:
    """Content and listing digests taken in this process, by path and signature (thread-safe:
    packages build in worker threads)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._files: dict[tuple[str, tuple[int, ...]], str] = {}
        self._listings: dict[tuple[str, tuple[int, ...], frozenset[str]], str] = {}
        self._looked: dict[tuple[str, str, tuple[int, ...], tuple[str, ...]], str] = {}
        #: the signatures taken while planning
        self._signatures: dict[str, tuple[int, ...]] = {}
        #: while planning, each memo table's entries looked at and those changed
        #: (`entries_changed`), by the table's id
        self._tables: dict[int, tuple[SharedEntries, set[int], set[int]]] = {}
        #: the signatures of the files whose time wsbuild itself set forward in this run
        self._advanced: dict[str, tuple[int, ...]] = {}
        #: the digests taken by earlier runs (record/file_digests.py), when the run keeps them
        self.kept: FileDigests | None = None

    def advanced(self, path: str) -> None:
        """Note that wsbuild just set the file's modification time (its content unchanged):
        while it keeps the signature it has now, that is no change a build may have missed."""
        signature = inputs.signature(path)
        with self._lock:
            self._advanced[path] = signature

    def advanced_to(self, path: str) -> tuple[int, ...] | None:
        with self._lock:
            return self._advanced.get(path)

    def signature(self, path: str, *, planning: bool = False) -> tuple[int, ...]:
        """The path's stat signature: while planning taken once per process (packages share
        most of what they read outside), else afresh (a build may have changed it)."""
        if planning:  # (one thread plans: a dict's get and set are atomic anyway)
            known = self._signatures.get(path)
            if known is not None:
                return known
        signature = inputs.signature(path)
        if planning:
            self._signatures[path] = signature
        return signature

    def lstat_signatures(self, paths: list[str]) -> list[tuple[int, ...]]:
        """While planning: each path's own signature (`lstat`), taken now; that of a path
        that is no symlink is its `signature` too, kept for the packages planned later
        (those reading a dependency's installed files stat them once)."""
        found = inputs.signatures(paths, follow_symlinks=False)
        known = self._signatures
        for path, seen in zip(paths, found):
            if not modes.S_ISLNK(seen[0]):
                known.setdefault(path, seen)
        return found

    def entries_changed(self, held: HeldEntries) -> set[int]:
        """While planning: the entries of the memo's table, among those `held` and those
        looked at before, whose path has another signature now than the one held (or whose
        digest was racy): the only ones a record holding them must look at again. Each entry
        of the table is looked at once for the whole plan, however many records hold it;
        each path stat'ed once."""
        table = held.table
        with self._lock:  # (the table is held here: its id is no other's meanwhile)
            state = self._tables.setdefault(id(table), (table, set(), set()))
        _, looked_at, changed = state
        pairs = table.pairs
        for ids in held.ids:
            unknown = set(ids)
            unknown -= looked_at
            if not unknown:
                continue
            order = sorted(unknown)
            paths = [pairs[index][0] for index in order]
            missing = [path for path in paths if path not in self._signatures]
            self._signatures.update(zip(missing, inputs.signatures(missing)))
            now = self._signatures
            for index, path in zip(order, paths):
                entry = pairs[index][1]
                seen = entry.seen if type(entry) is Looked else entry
                if now[path] != seen.signature or seen.digest == RACY_DIGEST:
                    changed.add(index)
            looked_at |= unknown
        return changed

    def file(self, path: str, signature: tuple[int, ...]) -> str:
        """The content digest of the file at `path` whose signature is `signature`."""
        if signature == inputs.ABSENT:
            return ABSENT_DIGEST
        if modes.S_ISDIR(signature[0]):
            return DIRECTORY_DIGEST
        with self._lock:
            known = self._files.get((path, signature))
        if known is None and self.kept is not None:
            known = self.kept.get(path, signature)
        if known is None:
            taken_ns = time.time_ns()
            try:
                known = content_digest(path)
            except OSError as exc:
                return f"unreadable:{exc.errno}"
            if self.kept is not None:
                self.kept.put(path, signature, known, taken_ns)
        with self._lock:
            self._files[(path, signature)] = known
        return known

    def listing(self, path: str, signature: tuple[int, ...],
                own: frozenset[str] = frozenset()) -> str:
        """The digest of the entries (name and type) of the directory at `path`, but `own`."""
        if signature == inputs.ABSENT:
            return ABSENT_DIGEST
        with self._lock:
            known = self._listings.get((path, signature, own))
        if known is None:
            known = listing_digest(path, own)
            with self._lock:
                self._listings[(path, signature, own)] = known
        return known


    def looked(self, kind: str, path: str, signature: tuple[int, ...],
               names: tuple[str, ...]) -> str:
        """The digest of a search (`kind` "search": the entries matching `names`, fnmatch
        patterns) or of probes ("probe": each of `names` there or not, and its type) of the
        directory at `path`."""
        key = (kind, path, signature, names)
        with self._lock:
            known = self._looked.get(key)
        if known is None:
            known = search_digest(path, names) if kind == "search" else probe_digest(path, names)
            with self._lock:
                self._looked[key] = known
        return known


def search_digest(path: str, patterns: Collection[str]) -> str:
    """The digest of the entries (name and type) of the directory at `path` whose names match
    one of `patterns`."""
    try:
        entries = inputs.scandir(path)
    except NotADirectoryError:
        return "not a directory"
    except FileNotFoundError:
        return ABSENT_DIGEST
    except OSError as exc:
        return f"unlistable:{exc.errno}"
    matcher = _matcher(tuple(sorted(patterns)))
    total = blake2b(digest_size=16)
    for entry in sorted(entries, key=lambda e: e.name):
        if matcher(entry.name):
            total.update(f"{entry.name}\0{_kind(entry)}\n".encode("utf-8", "surrogateescape"))
    return total.hexdigest()


@functools.lru_cache(maxsize=4096)
def _matcher(patterns: tuple[str, ...]) -> Callable[[str], bool]:
    """Whether a name matches one of `patterns`: a plain name, `NAME.*` (a module looked up:
    any suffix) or another fnmatch pattern."""
    import fnmatch
    import re

    exact = {p for p in patterns if not any(c in p for c in "*?[")}
    stems = tuple(p[:-1] for p in patterns if p.endswith(".*")
                  and not any(c in p[:-2] for c in "*?["))
    rest = [p for p in patterns if p not in exact and not (p.endswith(".*") and p[:-1] in stems)]
    compiled = re.compile("|".join(fnmatch.translate(p) for p in rest)) if rest else None

    def matches(name: str) -> bool:
        return name in exact or (bool(stems) and name.startswith(stems)) \
            or (compiled is not None and compiled.match(name) is not None)

    return matches


def _kind(entry: os.DirEntry[str]) -> str:
    try:
        return "l" if entry.is_symlink() else "d" if entry.is_dir() else "f"
    except OSError:
        return "?"


def path_kind(path: str) -> str:
    """What is at `path`: a directory (d), another file (f), a dangling link (l), nothing
    (n); declared as a stat."""
    try:
        return "d" if modes.S_ISDIR(inputs.stat(path).st_mode) else "f"
    except OSError:
        pass
    try:
        inputs.lstat(path)
    except OSError:
        return "n"
    return "l"


def probe_digest(directory: str, names: Collection[str]) -> str:
    """The digest of what is at each of `names` in `directory` (path_kind)."""
    total = blake2b(digest_size=16)
    base = directory.rstrip("/")
    for name in sorted(names):
        total.update(f"{name}\0{path_kind(f'{base}/{name}')}\n"
                     .encode("utf-8", "surrogateescape"))
    return total.hexdigest()


def listing_digest(path: str, own: Collection[str] = ()) -> str:
    """The digest of a directory's entries but `own`: each name with its type (file,
    directory, link, other); declared as a listing."""
    try:
        entries = inputs.scandir(path)
    except NotADirectoryError:
        return "not a directory"
    except OSError as exc:
        return f"unlistable:{exc.errno}"
    total = blake2b(digest_size=16)
    for entry in sorted(entries, key=lambda e: e.name):
        # wsbuild's own passing entries (a stage, a file being replaced) are no one's input
        if entry.name in own or entry.name == STAGE_DIR or entry.name.endswith(TEMP_SUFFIX):
            continue
        try:
            kind = "l" if entry.is_symlink() else "d" if entry.is_dir() else "f"
        except OSError:
            kind = "?"
        total.update(f"{entry.name}\0{kind}\n".encode("utf-8", "surrogateescape"))
    return total.hexdigest()


def take(files: Iterable[str], listings: Iterable[str], digests: Digests, *,
         searches: Mapping[str, Collection[str]] | None = None,
         probes: Mapping[str, Collection[str]] | None = None,
         started_ns: int = 0, own: OwnEntries = no_own_entries,
         settled: Mapping[str, str] | None = None) -> OutsideReads:
    """What a finished build read, as the record holds it (`own`: the package's own entries of
    each listed directory, left out; `searches` and `probes`: directory -> names). A path
    changed since `started_ns` (the build's start) may have changed after the build read it:
    it is held as racy, so the next check builds again; but a file of `settled` (path -> its
    digest before the steps ran: a time the build set forward itself) with that digest
    still, and a file as wsbuild left it when it set its time (`Digests.advanced`); nor a
    listing in a merged install base (what changes there during a build is what its listing
    leaves out: record/merged_owners.py)."""
    from wsbuild.record.merged_owners import in_merged_install  # lazy: off `list` and `graph`

    files, listings = sorted(set(files)), sorted(set(listings))

    def racy(signature: tuple[int, ...], directory_counts: bool) -> bool:
        return bool(started_ns) and signature != inputs.ABSENT \
            and max(signature[3:]) >= started_ns \
            and (directory_counts or not modes.S_ISDIR(signature[0]))

    def seen(path: str, listing: bool) -> Seen:
        signature = digests.signature(path)
        # a file's content may have changed after the build read it; a directory read as a
        # file counts by its type only, which its entries' changes leave alone
        digest = digests.listing(path, signature, own(path)) if listing \
            else digests.file(path, signature)
        if racy(signature, listing) and (
                not in_merged_install(path) if listing else
                (settled or {}).get(path) != digest and digests.advanced_to(path) != signature):
            return Seen(signature, RACY_DIGEST)
        return Seen(signature, digest)

    def looked(kind: str, path: str, names: Collection[str]) -> Looked:
        # only some names of the directory count: taken now, never racy (a directory such as
        # /tmp changes all the time, the names a step looked for in it seldom)
        ordered = tuple(sorted(set(names)))
        signature = digests.signature(path)
        return Looked(ordered, Seen(signature, digests.looked(kind, path, signature, ordered)))

    return OutsideReads({path: seen(path, False) for path in files},
                        {path: seen(path, True) for path in listings},
                        {path: looked("search", path, names)
                         for path, names in sorted((searches or {}).items())},
                        {path: looked("probe", path, names)
                         for path, names in sorted((probes or {}).items())})


def first_change(reads: OutsideReads, digests: Digests, *, planning: bool = False,
                 own: OwnEntries = no_own_entries, skip: str = "") -> str | None:
    """The first path whose content (or entries, but `own`) differs from `reads`, None when
    none does. A path whose signature is unchanged is not read. `planning`: each path stat'ed
    once for the whole plan; `skip`: a directory whose paths are not compared (what this run
    has yet to build)."""
    changes = changed_paths(reads, digests, planning=planning, own=own, skip=skip, first=True)
    return changes[0] if changes else None


def _changed(kind: str, path: str, entry: Seen | Looked, digests: Digests, own: OwnEntries,
             skip: str, planning: bool) -> bool:
    """Whether the entry of `kind` (file, listing, search, probe) holds another content now
    (one whose signature is unchanged is not read)."""
    if skip and (path + os.sep).startswith(skip):
        return False
    signature = digests.signature(path, planning=planning)
    seen = entry.seen if type(entry) is Looked else entry
    if signature == seen.signature and seen.digest != RACY_DIGEST:
        return False
    if type(entry) is Looked:
        now = digests.looked(kind, path, signature, entry.names)
    elif kind == "listing":
        now = digests.listing(path, signature, own(path))
    else:
        now = digests.file(path, signature)
    return now != seen.digest


def changed_paths(reads: OutsideReads, digests: Digests, *, planning: bool = False,
                  own: OwnEntries = no_own_entries, skip: str = "",
                  first: bool = False) -> list[str]:
    """Every path whose content, entries, matching entries or probed names differ from
    `reads` (`first`: stop at the first); see `first_change`. Records read from the memo
    are looked at only where an entry's signature changed (`Digests.entries_changed`)."""
    found: list[str] = []
    kinds = (("file", reads.files), ("listing", reads.listings), ("search", reads.searches),
             ("probe", reads.probes))
    if planning and reads.held is not None:
        changed = digests.entries_changed(reads.held)
        pairs = reads.held.table.pairs
        chosen: Sequence[tuple[str, Iterable[tuple[str, Seen | Looked]]]] = [
            (kind, [pairs[index] for index in ids if index in changed])
            for (kind, _), ids in zip(kinds, reads.held.ids) if not changed.isdisjoint(ids)]
    else:
        chosen = [(kind, held.items()) for kind, held in kinds]
    for kind, entries in chosen:  # in the record's order
        for path, entry in entries:
            if _changed(kind, path, entry, digests, own, skip, planning):
                found.append(path)
                if first:
                    return found
    return found


def refreshed(reads: OutsideReads, digests: Digests, *, own: OwnEntries = no_own_entries
              ) -> OutsideReads:
    """`reads` with this machine's signatures, where the content is the same (a restored
    entry's record, verified here, or a cut-off package's): the next check then stats only."""
    def again(path: str, seen: Seen, listing: bool) -> Seen:
        signature = digests.signature(path)
        if signature == seen.signature:
            return seen
        now = digests.listing(path, signature, own(path)) if listing \
            else digests.file(path, signature)
        return Seen(signature, now) if now == seen.digest else seen

    def again_looked(kind: str, path: str, looked: Looked) -> Looked:
        signature = digests.signature(path)
        if signature == looked.seen.signature:
            return looked
        now = digests.looked(kind, path, signature, looked.names)
        return Looked(looked.names, Seen(signature, now)) if now == looked.seen.digest \
            else looked

    return OutsideReads({p: again(p, s, False) for p, s in reads.files.items()},
                        {p: again(p, s, True) for p, s in reads.listings.items()},
                        {p: again_looked("search", p, s) for p, s in reads.searches.items()},
                        {p: again_looked("probe", p, s) for p, s in reads.probes.items()})
