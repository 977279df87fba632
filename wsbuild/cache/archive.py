"""Cache entries on disk: a package's installed files as a zstd-compressed tar.

Packing is deterministic (sorted members, no owners) and refuses trees a cache must not carry
(special files, setuid bits, links leaving the prefix). Unpacking trusts nothing: every member
is checked before it is written (once a link exists, also by the standard library's `data`
filter, which resolves it on disk) and created without following or replacing anything, so
nothing is ever written outside the destination.
"""

from __future__ import annotations

import hashlib
import os
import posixpath
import shutil
import stat
import tarfile
from collections.abc import Iterable
from pathlib import Path
from typing import BinaryIO

import zstandard

#: zstd level 3: better ratio than gzip -6 at several times its speed (docs/benchmarks.md)
ZSTD_LEVEL = 3
_HIGH_BITS = stat.S_ISUID | stat.S_ISGID | stat.S_ISVTX


class RefusedEntry(Exception):
    """A tree that cannot be packed, or an entry that must not be unpacked: one line why."""


def _link_escapes(name: str, target: str) -> bool:
    if target.startswith("/"):
        return True
    resolved = posixpath.normpath(posixpath.join(posixpath.dirname(name), target))
    return resolved == ".." or resolved.startswith("../")


def _tree(root: Path, files: Iterable[str] | None) -> list[str]:
    """Relative paths to pack: every directory, file and link below `root`, or `files` only."""
    if files is not None:
        return sorted(set(files))
    names: list[str] = []
    for dirpath, dirnames, filenames in os.walk(root):
        rel = os.path.relpath(dirpath, root)
        for name in dirnames + filenames:
            names.append(os.path.normpath(os.path.join(rel, name)))
    return sorted(names)


class _HashingWriter:
    """Counts and hashes what passes through to `out`."""

    def __init__(self, out: BinaryIO) -> None:
        self.out = out
        self.sha = hashlib.sha256()
        self.size = 0

    def write(self, data: bytes) -> int:
        self.sha.update(data)
        self.size += len(data)
        return self.out.write(data)


def _tar_info(root: Path, rel: str, hardlinks: dict[tuple[int, int], str]) -> tarfile.TarInfo:
    """The member for `root/rel`, without owner names (no passwd lookups) and with whole-second
    mtimes (no PAX header per member)."""
    path = os.path.join(root, rel)
    st = os.lstat(path)
    info = tarfile.TarInfo(rel)
    info.mode = stat.S_IMODE(st.st_mode)
    info.mtime = int(st.st_mtime)
    info.uid = info.gid = 0
    info.uname = info.gname = ""
    if stat.S_ISREG(st.st_mode):
        first = hardlinks.get((st.st_dev, st.st_ino)) if st.st_nlink > 1 else None
        if first is not None:
            info.type = tarfile.LNKTYPE
            info.linkname = first
        else:
            info.size = st.st_size
            if st.st_nlink > 1:
                hardlinks[(st.st_dev, st.st_ino)] = rel
    elif stat.S_ISDIR(st.st_mode):
        info.type = tarfile.DIRTYPE
    elif stat.S_ISLNK(st.st_mode):
        info.type = tarfile.SYMTYPE
        info.linkname = os.readlink(path)
    else:
        raise RefusedEntry(f"{rel} is a special file")
    return info


def pack(root: Path, out: BinaryIO, files: Iterable[str] | None = None) -> tuple[str, int]:
    """Write `root` (or just `files` below it) to `out` as tar.zst; (sha256, size) of the bytes.

    Raises RefusedEntry for a tree a cache entry must not hold."""
    hashing = _HashingWriter(out)
    compressor = zstandard.ZstdCompressor(level=ZSTD_LEVEL)
    hardlinks: dict[tuple[int, int], str] = {}
    with compressor.stream_writer(hashing, closefd=False) as zstd_out:  # type: ignore[arg-type]
        with tarfile.open(fileobj=zstd_out, mode="w|", format=tarfile.PAX_FORMAT) as tar:
            for rel in _tree(root, files):
                info = _tar_info(root, rel, hardlinks)
                if info.mode & _HIGH_BITS:
                    raise RefusedEntry(f"{rel} has a setuid, setgid or sticky bit")
                if info.issym() and _link_escapes(rel, info.linkname):
                    raise RefusedEntry(f"{rel} links outside the prefix ({info.linkname})")
                if info.isreg():
                    with open(os.path.join(root, rel), "rb") as handle:
                        tar.addfile(info, handle)
                else:
                    tar.addfile(info)
    return hashing.sha.hexdigest(), hashing.size


def check_member(member: tarfile.TarInfo) -> None:
    """Refuse what an install tree never holds; raise RefusedEntry naming the member."""
    name = member.name
    parts = name.split("/")
    if name.startswith("/") or not name.strip("./"):
        raise RefusedEntry(f"member with an absolute or empty path: {name!r}")
    if ".." in parts:
        raise RefusedEntry(f"member with '..' in its path: {name!r}")
    if not (member.isreg() or member.isdir() or member.issym() or member.islnk()):
        raise RefusedEntry(f"device or special file: {name!r}")
    if member.mode & _HIGH_BITS:
        raise RefusedEntry(f"setuid, setgid or sticky bit: {name!r}")
    if member.issym() and _link_escapes(name, member.linkname):
        raise RefusedEntry(f"link leading outside the prefix: {name!r} -> {member.linkname!r}")
    if member.islnk() and (member.linkname.startswith("/") or ".." in member.linkname.split("/")):
        raise RefusedEntry(f"hard link leading outside the prefix: {name!r} -> {member.linkname!r}")


def _safe_mode(member: tarfile.TarInfo) -> int:
    """What the standard library's `data` filter keeps: no group/other write; a file is
    readable and writable by its owner, executable by others only if by its owner."""
    mode = member.mode & ~0o022
    if member.isreg():
        mode |= 0o600
        if not mode & stat.S_IXUSR:
            mode &= ~(stat.S_IXGRP | stat.S_IXOTH)
    return mode


def unpack(source: BinaryIO, dest: Path) -> int:
    """Extract a tar.zst into the empty directory `dest`; the number of members.

    Raises RefusedEntry for a bad or truncated archive; `dest` may then hold part of it and is
    the caller's to discard — nothing outside `dest` is written."""
    if not hasattr(tarfile, "data_filter"):
        raise RefusedEntry("this Python has no tarfile extraction filters (3.10.12+ needed)")
    os.makedirs(dest, exist_ok=True)
    base = os.path.realpath(dest)
    count = 0
    links_seen = False
    made: set[str] = {""}
    directories: list[tuple[str, int, int]] = []
    try:
        reader = zstandard.ZstdDecompressor().stream_reader(source, closefd=False)
        with tarfile.open(fileobj=reader, mode="r|") as tar:  # type: ignore[call-overload]
            for member in tar:
                count += 1
                check_member(member)
                links_seen = links_seen or member.issym() or member.islnk()
                if links_seen:
                    # once a link exists on disk a path may run through it: the standard
                    # library's filter resolves the member against the disk (costly, so only
                    # from here on; before, the name checks above are complete)
                    try:
                        tarfile.data_filter(member, base)
                    except tarfile.FilterError as error:
                        raise RefusedEntry(str(error)) from None
                _write_member(tar, member, base, made, directories)
    except RefusedEntry:
        raise
    except (tarfile.TarError, zstandard.ZstdError, OSError, EOFError, ValueError) as error:
        raise RefusedEntry(f"unreadable archive: {error}") from None
    if count == 0:
        raise RefusedEntry("empty archive")
    # directories last (deepest first): a read-only one was still writable while it filled
    for path, mode, mtime in sorted(directories, reverse=True):
        os.chmod(path, mode)
        os.utime(path, (mtime, mtime))
    return count


_CREATE = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC


def _write_member(tar: tarfile.TarFile, member: tarfile.TarInfo, base: str, made: set[str],
                  directories: list[tuple[str, int, int]]) -> None:
    """Create one checked member below `base`: never following or replacing anything that is
    already there (O_EXCL, O_NOFOLLOW), with the packed mode minus group/other write."""
    name = member.name.rstrip("/")
    parent = os.path.dirname(name)
    if parent not in made:
        os.makedirs(os.path.join(base, parent), exist_ok=True)
        made.add(parent)
    path = os.path.join(base, name)
    mode = _safe_mode(member)
    if member.isdir():
        os.mkdir(path, 0o700)
        made.add(name)
        directories.append((path, mode, int(member.mtime)))
    elif member.issym():
        os.symlink(member.linkname, path)
    elif member.islnk():
        os.link(os.path.join(base, member.linkname), path, follow_symlinks=False)
    else:
        data = tar.extractfile(member)
        assert data is not None
        fd = os.open(path, _CREATE, 0o600)
        with open(fd, "wb") as out:
            shutil.copyfileobj(data, out, 1 << 20)
            os.fchmod(fd, mode)
            os.utime(fd, (member.mtime, member.mtime))


def file_digest(path: Path) -> tuple[str, int]:
    """(sha256, size) of a file."""
    sha = hashlib.sha256()
    size = 0
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            sha.update(chunk)
            size += len(chunk)
    return sha.hexdigest(), size
