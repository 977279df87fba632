"""The exception hierarchy: every expected failure says what, where and how to fix it."""

from __future__ import annotations

import errno
from pathlib import Path


class WsbuildError(Exception):
    """An expected error: the CLI prints it as one line and exits with `exit_code`."""

    exit_code = 2

    def __init__(
        self,
        message: str,
        *,
        path: Path | str | None = None,
        line: int | None = None,
        hint: str | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.path = Path(path) if path is not None else None
        self.line = line
        self.hint = hint

    def __str__(self) -> str:
        where = ""
        if self.path is not None:
            where = f"{self.path}:{self.line}: " if self.line else f"{self.path}: "
        text = f"{where}{self.message}"
        if self.hint:
            text += f" ({self.hint})"
        return text


class ManifestError(WsbuildError):
    """A package.xml (or other package description) is invalid."""


class ConditionError(ManifestError):
    """A REP 149 `condition` attribute cannot be parsed."""


class WorkspaceError(WsbuildError):
    """The workspace as a whole is inconsistent: duplicate names, bad layout, cycles."""


class CycleError(WorkspaceError):
    """The dependency graph has a cycle."""


class SelectionError(WsbuildError):
    """A `--packages-*` option names something that does not exist."""


class DependencyError(WsbuildError):
    """Build dependencies are missing before the build starts."""


class UnderlayError(WsbuildError):
    """The ROS underlay (e.g. a PyPI virtualenv) is unusable or needs repair."""


class TemplateError(WsbuildError):
    """`pkg create` cannot render a template."""


class BuildFailed(WsbuildError):
    """One or more packages failed to build (exit code 1)."""

    exit_code = 1


class Interrupted(WsbuildError):
    """The user pressed Ctrl-C (exit code 130)."""

    exit_code = 130


#: errno -> (what happened, what to do) for failures of the machine rather than of wsbuild
_ENVIRONMENT_ERRNOS: dict[int, tuple[str, str]] = {
    errno.ENOSPC: ("no space left on device", "free space and build again"),
    errno.EDQUOT: ("disk quota exceeded", "free space or raise the quota, and build again"),
    errno.EROFS: ("read-only file system",
                  "make it writable or choose another --build-base/--install-base"),
    errno.EACCES: ("permission denied",
                   "make it writable for this user or choose another --build-base/--install-base"),
    errno.EPERM: ("operation not permitted",
                  "make it writable for this user or choose another --build-base/--install-base"),
    errno.EMFILE: ("too many open files", "raise the limit (ulimit -n) and build again"),
    errno.ENFILE: ("too many open files in the system", "close programs and build again"),
    errno.ENOMEM: ("out of memory", "free memory or build with fewer --parallel-workers"),
    errno.EIO: ("input/output error", "check the disk (dmesg) and build again"),
}


def environment_failure(exc: OSError, *, doing: str, program: str | None = None) -> str | None:
    """One line for an `OSError` the machine caused, or None when it is not one (then it is a
    bug). `doing`: what wsbuild was doing ("building pkg"); `program`: the command it was
    starting, if any, so that a missing program is named as such."""
    filename = exc.filename if isinstance(exc.filename, str) else None
    if isinstance(exc, FileNotFoundError) and program is not None and filename == program:
        return (f"'{program}' is not installed or not on PATH (needed while {doing}): install "
                f"it, or put the directory holding it on PATH, and build again")
    known = _ENVIRONMENT_ERRNOS.get(exc.errno or 0)
    if known is None:
        return None
    what, fix = known
    # a copy names its source first and its destination second: the destination is the problem
    target = exc.filename2 if isinstance(exc.filename2, str) else filename
    where = f" ({target})" if target else ""
    return f"{what} while {doing}{where}: {fix}"
