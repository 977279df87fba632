"""The test oracle of declared inputs: with `WSBUILD_INPUTS_ORACLE` naming a file (the test
suite sets it), a recorded run also wraps the process's own file functions (stat, lstat,
scandir, listdir, open for reading, readlink) and, at its end, appends to that file every
path it accessed that no declaration (wsbuild/inputs.py) covers, with the wsbuild code that
did it. Never on in a user's run: the record holds the declared inputs only."""

from __future__ import annotations

import builtins
import io
import os
import sys
from collections.abc import Callable, Mapping
from typing import Any

#: the environment variable naming the oracle's file
ORACLE_VARIABLE = "WSBUILD_INPUTS_ORACLE"
#: beside the oracle's file, one line per run it checked: accesses traced, undeclared, argv, cwd
CHECKED_SUFFIX = ".checked"


class InputsOracle:
    """Traces the process's own file accesses from `install` to `uninstall`."""

    def __init__(self, file: str, cwd: str) -> None:
        self.file = file
        self.cwd = cwd
        #: (absolute path, follows symlinks) -> the wsbuild code that accessed it
        self.traced: dict[tuple[str, bool], str] = {}
        self.traced_listed: dict[str, str] = {}
        self.active = False
        self._saved: list[tuple[object, str, object]] = []

    @classmethod
    def from_environment(cls, cwd: str) -> InputsOracle | None:
        file = os.environ.get(ORACLE_VARIABLE)
        return cls(file, cwd) if file else None

    def _absolute(self, path: object) -> str | None:
        if type(path) is not str:
            if not isinstance(path, (str, bytes, os.PathLike)):
                return None
            path = os.fsdecode(path)
        return path if path[:1] == "/" else os.path.join(self.cwd, path)  # type: ignore[index]

    def _watched(self, call: Callable[..., Any], path: Any, follow: bool,
                 *args: Any, **kwargs: Any) -> Any:
        """`call(path, ...)`, noting `path` (the first time), whatever came of it."""
        self._saw(path, follow)
        return call(path, *args, **kwargs)

    def _saw(self, path: object, follow: bool) -> None:
        if not self.active:
            return
        name = self._absolute(path)
        if name is not None and (name, follow) not in self.traced:
            self.traced[(name, follow)] = _caller()

    def _note_listed(self, path: object) -> None:
        name = self._absolute(path) if self.active else None
        if name is not None and name not in self.traced_listed:
            self.traced_listed[name] = _caller()

    def install(self) -> None:
        """Wrap the process's file functions, noting every access (the oracle)."""
        watched, note_listed = self._watched, self._note_listed
        os_stat, scandir, listdir = os.stat, os.scandir, os.listdir
        os_open, readlink, file_open = os.open, os.readlink, builtins.open
        saw = self._saw

        def watched_stat(path: Any, *, dir_fd: Any = None,
                         follow_symlinks: bool = True) -> os.stat_result:
            if dir_fd is None:
                saw(path, follow_symlinks)
            return os_stat(path, dir_fd=dir_fd, follow_symlinks=follow_symlinks)

        def watched_lstat(path: Any, *, dir_fd: Any = None) -> os.stat_result:
            return watched_stat(path, dir_fd=dir_fd, follow_symlinks=False)

        def watched_scandir(path: Any = ".") -> Any:
            note_listed(path)
            return scandir(path)

        def watched_listdir(path: Any = ".") -> list[Any]:
            note_listed(path)
            return listdir(path)

        def watched_os_open(path: Any, *args: Any, dir_fd: Any = None, **kwargs: Any) -> int:
            flags = args[0] if args else kwargs.get("flags", 0)
            if dir_fd is not None or flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
                # a file the run writes is its output, not an input
                return os_open(path, *args, dir_fd=dir_fd, **kwargs)
            return watched(os_open, path, True, *args, **kwargs)

        def watched_readlink(path: Any, *, dir_fd: Any = None) -> Any:
            if dir_fd is not None:
                return readlink(path, dir_fd=dir_fd)
            return watched(readlink, path, False)

        def watched_open(file: Any, *args: Any, **kwargs: Any) -> Any:
            mode = args[0] if args else kwargs.get("mode", "r")
            if any(c in mode for c in "wax+"):  # written: an output, not an input
                return file_open(file, *args, **kwargs)
            return watched(file_open, file, True, *args, **kwargs)

        for owner, name, value in ((os, "stat", watched_stat), (os, "lstat", watched_lstat),
                                   (os, "scandir", watched_scandir),
                                   (os, "listdir", watched_listdir),
                                   (os, "open", watched_os_open),
                                   (os, "readlink", watched_readlink),
                                   (builtins, "open", watched_open), (io, "open", watched_open)):
            self._saved.append((owner, name, getattr(owner, name)))
            setattr(owner, name, value)
        self.active = True

    def uninstall(self) -> None:
        self.active = False
        for owner, name, value in reversed(self._saved):
            setattr(owner, name, value)
        self._saved.clear()

    def report_undeclared(self, seen: Mapping[tuple[str, bool], object], listed: set[str],
                          outputs: tuple[str, ...]) -> None:
        """Append to the oracle's file every access no declaration covers (`seen`: declared
        paths, `listed`: declared listings; `outputs`: what the run writes, not inputs)."""
        prefixes = tuple(path + os.sep for path in outputs if path)
        stdlib, sites = _interpreter_paths(), _sites()

        def exempt(path: str) -> bool:
            probe = path + os.sep
            return probe.startswith(stdlib) and not probe.startswith(sites)

        # realpath() of the interpreter (sysconfig, site) lstats each of its ancestors
        interpreter_ancestors = {
            spelling[:i + 1] for spelling in (sys.base_prefix + os.sep, sys.executable + os.sep,
                                              os.path.realpath(sys.executable) + os.sep)
            for i, c in enumerate(spelling) if c == os.sep} | _links_of(sys.executable)
        declared = {path for path, _ in seen}
        lines = []
        for (path, follow), caller in sorted(self.traced.items()):
            if path in declared or path in listed or path.rpartition("/")[0] in listed \
                    or exempt(path) \
                    or (path + os.sep).startswith(prefixes) \
                    or (not follow and path + os.sep in interpreter_ancestors):
                continue
            lines.append(f"{path}\t{'stat' if follow else 'lstat'}\t{caller}\n")
        for path, caller in sorted(self.traced_listed.items()):
            if path in listed or path in declared or exempt(path) \
                    or (path + os.sep).startswith(prefixes):
                continue
            lines.append(f"{path}\tlisting\t{caller}\n")
        if lines:
            with open(self.file, "a", encoding="utf-8") as handle:
                handle.write(f"# wsbuild {' '.join(sys.argv[1:])} in {self.cwd}\n")
                handle.writelines(lines)
        # what it checked, so that an oracle switched off is seen: a run it traced writes
        # how many accesses it held to the declarations (tests/test_inputs_oracle.py)
        with open(self.file + CHECKED_SUFFIX, "a", encoding="utf-8") as handle:
            handle.write(f"{len(self.traced) + len(self.traced_listed)}\t{len(lines)}\t"
                         f"{' '.join(sys.argv[1:])}\t{self.cwd}\n")


def _caller() -> str:
    """The wsbuild code that made an access (the oracle names it)."""
    frame = sys._getframe(2)
    while frame is not None:
        name = frame.f_code.co_filename
        if "/wsbuild/" in name and not name.endswith(
                ("/inputs.py", "/recording.py", "/inputs_oracle.py")):
            return f"{name.rpartition('/wsbuild/')[2]}:{frame.f_lineno} {frame.f_code.co_name}"
        frame = frame.f_back
    return "?"


def _links_of(path: str) -> set[str]:
    """The symlinks `path` resolves through, each with a trailing separator."""
    found: set[str] = set()
    while os.path.islink(path) and path + os.sep not in found:
        found.add(path + os.sep)
        path = os.path.join(os.path.dirname(path), os.readlink(path))
    return found


def _interpreter_paths() -> tuple[str, ...]:
    """The one exemption: the interpreter's own standard library (the record's key names the
    interpreter by its path and version), the base interpreter's `lib/pythonX.Y` without its
    site-packages. Nothing else: a venv's `lib/pythonX.Y` holds its site-packages (the ROS
    wheels, ament_index_python's resources), and for a venv made from /usr/bin/python3
    `sys.base_prefix` is /usr, whose headers, CMake modules and .pc files a plan must
    declare."""
    import sysconfig

    paths = sysconfig.get_paths()
    return (paths["stdlib"].rstrip(os.sep) + os.sep,)


def _sites() -> tuple[str, ...]:
    """The interpreter's site directories: never exempt, wherever they lie."""
    import site
    import sysconfig

    paths = sysconfig.get_paths()
    found = {paths[key] for key in ("purelib", "platlib")} | set(site.getsitepackages())
    return tuple(sorted(path.rstrip(os.sep) + os.sep for path in found))
