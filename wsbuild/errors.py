"""The exception hierarchy: every expected failure says what, where and how to fix it."""

from __future__ import annotations

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
