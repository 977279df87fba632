"""Small typed events the work emits; the reporter decides what a user sees."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from wsbuild.workspace.model import BuildResult


@dataclass(frozen=True, slots=True)
class JobStarted:
    package: str


@dataclass(frozen=True, slots=True)
class StepStarted:
    package: str
    label: str


@dataclass(frozen=True, slots=True)
class JobFinished:
    result: BuildResult


@dataclass(frozen=True, slots=True)
class Notice:
    """A message not tied to one package's result (e.g. waiting for a lock)."""

    text: str
    package: str | None = None
    warning: bool = False


@dataclass(frozen=True, slots=True)
class CacheRestored:
    """A package was installed from the build cache instead of being built."""

    package: str
    source: str


@dataclass(frozen=True, slots=True)
class RunFinished:
    results: tuple[BuildResult, ...]
    seconds: float
    verb: str = "build"
    #: lines the summary ends with (compiler cache counts, `--timings` table)
    details: tuple[str, ...] = ()


Event = JobStarted | StepStarted | JobFinished | Notice | CacheRestored | RunFinished
Emit = Callable[[Event], None]
