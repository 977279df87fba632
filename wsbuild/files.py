"""Writing whole files: atomically, only when their content changes, or only when missing."""

from __future__ import annotations

import itertools
import os
import stat
from collections.abc import Mapping
from pathlib import Path

from wsbuild import inputs

#: numbers the temporary files of one process (with its pid: unique among writers)
_UNIQUE = itertools.count()

#: what a temporary file beside its target ends with (it also starts with a dot, so the prefix
#: indexes and fingerprints, which skip hidden files, never see one)
TEMP_SUFFIX = ".wsbuild-tmp"
#: the directory of the install base where packages are staged during a run (prefix/stage.py)
STAGE_DIR = ".wsbuild-stage"


def atomic_write(path: Path, content: str | bytes, *, mode: int | None = None,
                 keep_mode: bool = False, durable: bool = False) -> None:
    """Replace `path` by `content` (text is written as UTF-8) in one step.

    The content goes to a temporary file beside `path` that is renamed over it, so a reader (a
    shell sourcing the file, another build) sees the old file or the new one, never half of
    one; on any failure the temporary file is removed and `path` is untouched. A symlink at
    `path` is replaced, never written through.

    `mode`: the file's permission bits (None: those of a new file, 0o666 less the umask);
    `keep_mode`: a file already at `path` keeps its bits; `durable`: fsync before the rename,
    for files whose loss costs more than the time (the underlay's own files).
    """
    data = content.encode() if isinstance(content, str) else content
    if keep_mode:
        try:
            mode = path.stat().st_mode & 0o7777
        except FileNotFoundError:
            pass
    # a unique name (not mkstemp: its 0o600 would ignore the umask) so concurrent writers of
    # one path never share a temporary file
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{next(_UNIQUE)}{TEMP_SUFFIX}")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            if durable:
                handle.flush()
                os.fsync(handle.fileno())
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def write_if_changed(path: Path, content: str, *, mode: int | None = None) -> bool:
    """Write `content` to `path` (atomically, creating its directory) unless it already holds
    exactly that, so its mtime stays put; True if written.

    A symlink at `path` is replaced rather than written through (as colcon does), so a
    `--symlink-install` never edits a file in the source tree.
    """
    data = content.encode()
    try:
        link = stat.S_ISLNK(inputs.lstat(path).st_mode)
    except OSError:
        link = False
    if not link:
        try:
            if inputs.read_bytes(path) == data:
                return False
        except (FileNotFoundError, NotADirectoryError):
            pass
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, data, mode=mode)
    return True


def create_if_missing(path: Path, content: str = "") -> bool:
    """Create `path` with `content` unless something (even a dangling symlink) is there."""
    try:
        inputs.lstat(path)
    except OSError:
        pass
    else:
        return False
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(content)
    return True


def user_cache_dir(environ: Mapping[str, str], name: str) -> Path:
    """Where the tool `name` keeps its cache for this user: `$XDG_CACHE_HOME/<name>`, else
    `~/.cache/<name>` (the XDG base directory rule: the one rule for every cache wsbuild keeps
    or finds)."""
    return Path(environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / name


def wsbuild_cache_dir(environ: Mapping[str, str]) -> Path:
    """wsbuild's own cache (the build cache's local tier, the dependency index's answers):
    `WSBUILD_CACHE_DIR`, else `user_cache_dir(environ, "wsbuild")`."""
    chosen = environ.get("WSBUILD_CACHE_DIR")
    return Path(chosen) if chosen else user_cache_dir(environ, "wsbuild")


def private_directory(path: Path) -> Path:
    """`path` made (with its parents) and kept readable by its owner only (0o700): what
    wsbuild keeps for itself there is nobody else's to read."""
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        pass
    except FileNotFoundError:  # its parents first (never statted when they are there)
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.mkdir(path, 0o700)
        except FileExistsError:
            pass
    # lstat (and no Path.mkdir(exist_ok=True), which stats): only the directory's identity
    # and mode matter here, so a no-op's record holds no more of it (its times change with
    # every file made in it)
    if inputs.lstat(path).st_mode & 0o077:
        path.chmod(0o700)
    return path
