"""The inputs of a run that plans or only reads: every file, directory listing and program it
consults goes through these functions, which do the access and declare it.

The no-op replay (engine/replay.py) answers a command again only while every declared input
of its last run compares equal, each in its own way:
- `stat` / `lstat` / `exists` / `is_file` / `is_dir`: the path's stat signature as the run
  saw it (type and mode, inode, size, modification and change time; absent is a signature);
- `read_text` / `read_bytes` / `declare_file`: the file's stat signature at the run's end (a
  file gone by then spoils the record);
- `scandir` / `listdir` / `declare_directory`: the directory's entries, each by its lstat
  signature, and through a symlink also its target's;
- `which`: every candidate on the search path, as `stat` (a program installed earlier on
  PATH changes the answer);
the environment, the command line, the interpreter and wsbuild's version are compared by the
record's key (engine/replay.py). What a program that wsbuild starts reads is declared by the
code that starts it (`declare_directory` for pkg-config's search path). A path a run could
not read (a symlink loop, no permission) spoils the record: that run is never replayed.

Nothing listens unless a run is recorded: then these are plain os calls. Under
`WSBUILD_INPUTS_ORACLE` (the test suite) engine/recording.py also traces the process's own
file accesses and writes down any that no declaration covers: a test fails naming them."""

from __future__ import annotations

import os
import stat as modes
from collections.abc import Callable, Iterable
from typing import TypeVar

from wsbuild.signature import stat_signature

#: (absolute or relative path, kind, what the run saw: a stat signature, ABSENT or None)
Listener = Callable[[str, str, "tuple[int, ...] | None"], None]
STAT, LSTAT, FILE, LISTING, DECLARED, UNREADABLE, UNRECORDED, MEMO = (
    "stat", "lstat", "file", "listing", "declared", "unreadable", "unrecorded", "memo")
ABSENT: tuple[int, ...] = (0, 0, 0, 0, 0)
_listeners: list[Listener] = []
#: a listener's way to hear a batch at once (`listen(many=...)`), by listener
_batch: dict[Listener, Callable[[list[tuple[str, str, "tuple[int, ...] | None"]]], None]] = {}


def _notify(path: str | os.PathLike[str], kind: str, seen: tuple[int, ...] | None) -> None:
    if _listeners:
        name = os.fspath(path)
        for listener in _listeners:
            listener(name, kind, seen)


_signature = stat_signature


_T = TypeVar("_T")


def _declared(path: str | os.PathLike[str], kind: str, access: Callable[[], _T],
              seen: Callable[[_T], tuple[int, ...] | None] = lambda _: None) -> _T:
    """`access()` of `path`, declared as `kind` (a missing path as absent, an unreadable one
    as unreadable); `seen`: what the run saw of it, from the result."""
    try:
        result = access()
    except (FileNotFoundError, NotADirectoryError):
        _notify(path, STAT if kind in (FILE, LISTING) else kind, ABSENT)
        raise
    except OSError:
        _notify(path, UNREADABLE, None)
        raise
    _notify(path, kind, seen(result))
    return result


def stat(path: str | os.PathLike[str], *, follow_symlinks: bool = True) -> os.stat_result:
    """os.stat, declared."""
    return _declared(path, STAT if follow_symlinks else LSTAT,
                     lambda: os.stat(path, follow_symlinks=follow_symlinks), _signature)


def lstat(path: str | os.PathLike[str]) -> os.stat_result:
    return stat(path, follow_symlinks=False)


def signature(path: str | os.PathLike[str]) -> tuple[int, ...]:
    """What a change to the file at `path` (through symlinks) changes: type and mode, inode,
    size, modification and change times; ABSENT when it cannot be stat'ed. Declared."""
    try:
        return _signature(stat(path))
    except OSError:
        return ABSENT


def signatures(paths: Iterable[str], *, follow_symlinks: bool = True
               ) -> list[tuple[int, ...]]:
    """`signature` of each of `paths` (`follow_symlinks=False`: of the path itself, as
    `lstat`), declared as each would be: one loop for what a plan stats by the thousand (a
    record's installed files, what packages read outside), without a call per layer."""
    kind = STAT if follow_symlinks else LSTAT
    found: list[tuple[int, ...]] = []
    heard: list[tuple[str, str, tuple[int, ...] | None]] = []
    take = os.stat
    for path in paths:
        try:
            seen = _signature(take(path, follow_symlinks=follow_symlinks))
            heard.append((path, kind, seen))
        except (FileNotFoundError, NotADirectoryError):
            seen = ABSENT
            heard.append((path, kind, ABSENT))
        except OSError:
            seen = ABSENT
            heard.append((path, UNREADABLE, None))
        found.append(seen)
    for listener in _listeners:
        many = _batch.get(listener)
        if many is not None:
            many(heard)
            continue
        for name, said, seen in heard:
            listener(name, said, seen)
    return found


def exists(path: str | os.PathLike[str]) -> bool:
    try:
        stat(path)
    except OSError:
        return False
    return True


def is_file(path: str | os.PathLike[str]) -> bool:
    try:
        return modes.S_ISREG(stat(path).st_mode)
    except OSError:
        return False


def is_dir(path: str | os.PathLike[str]) -> bool:
    try:
        return modes.S_ISDIR(stat(path).st_mode)
    except OSError:
        return False


def read_bytes(path: str | os.PathLike[str]) -> bytes:
    """The file's content, declared (its signature is taken at the run's end)."""
    def read() -> bytes:
        with open(path, "rb") as handle:
            return handle.read()

    return _declared(path, FILE, read)


def read_text(path: str | os.PathLike[str], encoding: str = "utf-8",
              errors: str = "strict") -> str:
    return read_bytes(path).decode(encoding, errors)


def scandir(path: str | os.PathLike[str]) -> list[os.DirEntry[str]]:
    """The directory's entries (a list), declared as a listing."""
    def listing() -> list[os.DirEntry[str]]:
        with os.scandir(path) as entries:
            return list(entries)

    return _declared(path, LISTING, listing)


def listdir(path: str | os.PathLike[str]) -> list[str]:
    return [entry.name for entry in scandir(path)]


def which(name: str, path: str | None = None) -> str | None:
    """shutil.which for a plain program name, every candidate declared."""
    if os.sep in name:
        return name if is_file(name) and os.access(name, os.X_OK) else None
    search = os.environ.get("PATH", os.defpath) if path is None else path
    for directory in search.split(os.pathsep):
        if not directory:
            continue
        candidate = os.path.join(directory, name)
        try:
            st = stat(candidate)
        except OSError:
            continue
        if modes.S_ISREG(st.st_mode) and os.access(candidate, os.X_OK):
            return candidate
    return None


def declare_file(path: str | os.PathLike[str]) -> None:
    """The run's answer depends on the file at `path` (or on its absence), read by another
    program."""
    _notify(path, DECLARED, None)


def declare_memo(path: str | os.PathLike[str]) -> None:
    """A file wsbuild keeps for itself, read: what it answers is derived from inputs that are
    declared and checked against them (a digest by its file's signature), so it is no input of
    a record itself."""
    _notify(path, MEMO, None)


def declare_unrecorded(why: str) -> None:
    """This run read more than it declares, and its later runs do not (the underlay's full
    scan, which they answer from a stamp): it is never answered from a record."""
    _notify(why, UNRECORDED, None)


def declare_directory(path: str | os.PathLike[str]) -> None:
    """The run's answer depends on which entries the directory at `path` holds (and on each
    entry's signature): another program searched it."""
    _notify(path, LISTING, None)


def listen(listener: Listener,
           many: Callable[[list[tuple[str, str, tuple[int, ...] | None]]], None] | None = None
           ) -> Callable[[], None]:
    """Hear every declaration until the returned function is called; `many`: what hears the
    thousands `signatures` declares at once, as `listener` would one by one."""
    _listeners.append(listener)
    if many is not None:
        _batch[listener] = many

    def stop() -> None:
        if listener in _listeners:
            _listeners.remove(listener)
        _batch.pop(listener, None)

    return stop


def glob_dirs(directory: str | os.PathLike[str], pattern: str) -> list[str]:
    """The subdirectories of `directory` whose names match `pattern` (fnmatch), sorted:
    the listing and each match declared."""
    import fnmatch

    try:
        names = listdir(directory)
    except OSError:
        return []
    return sorted(os.path.join(directory, name) for name in names
                  if fnmatch.fnmatchcase(name, pattern)
                  and is_dir(os.path.join(directory, name)))


def walk_files(top: str | os.PathLike[str]) -> list[str]:
    """Every file under `top` (following symlinks to directories; hidden directories
    skipped), sorted by directory then name: each listing declared."""
    found: list[str] = []
    stack = [os.fspath(top)]
    while stack:
        directory = stack.pop()
        try:
            entries = sorted(scandir(directory), key=lambda e: e.name)
        except OSError:
            continue
        subdirectories = []
        for entry in entries:
            if is_dir(entry.path):
                if not entry.name.startswith("."):
                    subdirectories.append(entry.path)
            else:
                found.append(entry.path)
        stack.extend(reversed(subdirectories))
    return found


def realpath(path: str | os.PathLike[str]) -> str:
    """os.path.realpath, every component of the absolute path declared (by lstat: a
    directory replaced by a symlink changes the answer)."""
    absolute = os.path.abspath(path)
    real = os.path.realpath(absolute)
    for spelling in dict.fromkeys((absolute, real)):  # the path as given and as resolved
        current = ""
        for part in spelling.split(os.sep)[1:]:
            current = f"{current}{os.sep}{part}"
            try:
                lstat(current)
            except OSError:
                break
    return real


def declare_translations(domain: str) -> None:
    """gettext looks for a translation of `domain`'s messages in the interpreter's locale
    directory for each language of the environment (argparse's help and errors come through
    it): each place it looks is an input of what a command prints, declared here."""
    import gettext
    import sys

    expand = getattr(gettext, "_expand_lang", None)
    if expand is None:
        return
    languages: list[str] = []
    for variable in ("LANGUAGE", "LC_ALL", "LC_MESSAGES", "LANG"):
        value = os.environ.get(variable)
        if value:
            languages = value.split(":")
            break
    localedir = os.path.join(sys.base_prefix, "share", "locale")
    for language in [*languages, "C"]:
        for name in expand(language):
            if name != "C":
                exists(os.path.join(localedir, name, "LC_MESSAGES", f"{domain}.mo"))
