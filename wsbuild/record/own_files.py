"""A package's own files, as its record holds them: every file below the package's directory,
with no directory skipped for its name (a Python subpackage `log/`, a test fixture under
`build/`, a vendored subdirectory marked COLCON_IGNORE that CMake builds), except by one rule:

- the workspace's own build, install and log bases (and any other output base the run names),
  when they lie inside the package (a workspace built in the package's own directory);
- version-control metadata (`.git`, `.hg`, `.svn`, `.bzr`, `CVS`) and the caches Python and
  pytest write beside sources while tests run (`__pycache__`, `.pytest_cache`), by name at
  any depth: none of them is read by a build, and a `wsbuild test` run writes the last two.

Each file is held by its content digest, taken only when its stat signature (size,
modification and change times, inode: what git's index compares) differs from the last
record's, so a check costs stats, not reads. A file reached through a symlink counts by its
target's content and the link's own target path; a dangling link and an unreadable path count
too (a change to either shows)."""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from wsbuild import inputs
from wsbuild.hashes import blake2b, sha256_stream

#: names never part of a package's own files, at any depth (the one rule)
LEFT_OUT = frozenset({".git", ".hg", ".svn", ".bzr", "CVS", "__pycache__", ".pytest_cache"})
#: what a symlink's own entry, a dangling link, an unreadable path and a directory that cannot
#: be listed are recorded as (a suffix of the relative path)
LINK, DANGLING, UNREADABLE, UNLISTABLE = "\0link", "\0dangling", "\0unreadable", "\0unlistable"


class OwnFile(NamedTuple):
    """One file of the package: its stat signature when its digest was taken, and the digest.
    (A named tuple: a plan reads thousands of them, and a tuple is made fastest.)"""

    size: int
    mtime_ns: int
    digest: str
    ctime_ns: int = 0
    inode: int = 0

    def same_stat(self, stat: os.stat_result) -> bool:
        return (self.size == stat.st_size and self.mtime_ns == stat.st_mtime_ns
                and self.ctime_ns == stat.st_ctime_ns and self.inode == stat.st_ino)

    def as_list(self) -> list[object]:
        return list(self)


@dataclass(slots=True)
class OwnFiles:
    """A package's files now: relative path -> what was seen, their digest, and which changed
    since the record they were compared with."""

    files: dict[str, OwnFile]
    digest: str
    changed: list[str] = field(default_factory=list)


def package_files(root: Path, outputs: Iterable[str] = ()
                  ) -> Iterator[tuple[str, os.DirEntry[str] | None]]:
    """(path relative to `root`, its entry) of every file of the package, directories depth
    first in name order; a directory that cannot be listed comes as (its path + UNLISTABLE,
    None). `outputs`: absolute directories inside which nothing counts (the workspace's bases).
    Symlinked directories are followed, each real directory once. Each listing is declared
    (wsbuild/inputs.py)."""
    skipped = {os.path.normpath(path) for path in outputs}
    # (relative path, the directory's real path); a symlinked directory's real path is
    # resolved, the others' follow from their parent's (no stat each)
    stack = [("", str(root))]
    linked: set[str] = set()
    while stack:
        rel_dir, real_dir = stack.pop()
        directory = os.path.join(root, rel_dir) if rel_dir else str(root)
        try:
            entries = inputs.scandir(directory)
        except OSError:
            yield rel_dir + UNLISTABLE, None
            continue
        for entry in entries:
            name = entry.name
            if name in LEFT_OUT:
                continue
            rel = f"{rel_dir}/{name}" if rel_dir else name
            try:
                is_dir = entry.is_dir()  # follows symlinks
            except OSError:
                is_dir = False
            if not is_dir:
                yield rel, entry
                continue
            if skipped and os.path.normpath(entry.path) in skipped:
                continue
            real = os.path.join(real_dir, name)
            if entry.is_symlink():
                real = inputs.realpath(entry.path)
                # a link to a directory above, or to one already walked: a loop or a repeat
                if real in linked or (real_dir + os.sep).startswith(real + os.sep):
                    continue
                linked.add(real)
            stack.append((rel, real))


def _signatures(root: Path, outputs: Iterable[str]) -> Iterator[tuple[str, os.stat_result | None]]:
    """Each file of the package with its signature through symlinks; a symlink's own entry, a
    dangling link and an unreadable file as well (None: a directory that cannot be listed)."""
    for rel, entry in package_files(root, outputs):
        if entry is None:
            yield rel, None
            continue
        try:
            # os.stat, not entry.stat(): through a symlink to its target (what the build reads)
            stat = inputs.stat(entry.path)
        except FileNotFoundError:
            if entry.is_symlink():  # a dangling link: the build sees it missing
                yield rel + DANGLING, inputs.lstat(entry.path)
            continue
        except OSError:  # a link loop, an unreadable file
            yield rel + UNREADABLE, inputs.lstat(entry.path)
            continue
        yield rel, stat
        if entry.is_symlink():  # where it points counts too (the target may be unchanged)
            yield rel + LINK, inputs.lstat(entry.path)


def content_digest(path: str) -> str:
    """A file's content digest (raises OSError): SHA-256, which CPUs compute in hardware
    (twice BLAKE2's speed where they do), cut to 128 bits."""
    digest = sha256_stream()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()[:32]


def own_files(root: Path, previous: Mapping[str, OwnFile], outputs: Iterable[str] = ()
              ) -> OwnFiles:
    """Every file of the package with its content digest, reusing `previous`'s digest where
    the stat signature is unchanged; `changed` names the files added, removed or changed."""
    files: dict[str, OwnFile] = {}
    changed: list[str] = []
    for rel, stat in _signatures(root, outputs):
        old = previous.get(rel)
        if stat is None:
            files[rel] = OwnFile(0, 0, "unlistable")
            if old is None:
                changed.append(rel.partition("\0")[0])
            continue
        if old is not None and old.same_stat(stat):
            files[rel] = old
            continue
        if rel.endswith((LINK, DANGLING, UNREADABLE)):
            path = os.path.join(root, rel.partition("\0")[0])
            try:
                target = os.readlink(path)
            except OSError:
                target = ""
            digest = f"{rel.rpartition(chr(0))[2]}:{target}"
        else:
            try:
                digest = content_digest(os.path.join(root, rel))
            except OSError:
                digest = "unreadable"
        files[rel] = OwnFile(stat.st_size, stat.st_mtime_ns, digest, stat.st_ctime_ns,
                             stat.st_ino)
        if old is None or old.digest != digest:
            changed.append(rel.partition("\0")[0])
    removed = [rel.partition("\0")[0] for rel in previous if rel not in files]
    return OwnFiles(files, files_digest(files), sorted(set(changed + removed)))


def files_digest(files: Mapping[str, OwnFile]) -> str:
    """One digest of the files' paths and contents."""
    total = blake2b(digest_size=16)
    for rel in sorted(files):
        total.update(f"{rel}\0{files[rel].digest}\n".encode("utf-8", "surrogateescape"))
    return total.hexdigest()


def stat_digest(root: Path, outputs: Iterable[str] = (), extra: Iterable[Path] = ()) -> str:
    """One digest of the stat signatures of the package's files (and of `extra` files): what a
    test run compares to see an edit made since the last run without hashing anything."""
    found = [(rel, inputs.signature(entry.path) if entry is not None else ())
             for rel, entry in package_files(root, outputs)]
    found += [(str(path), inputs.signature(path)) for path in extra]
    total = blake2b(digest_size=16)
    for rel, signature in sorted(found):
        total.update(f"{rel}\0{signature}\n".encode("utf-8", "surrogateescape"))
    return total.hexdigest()
