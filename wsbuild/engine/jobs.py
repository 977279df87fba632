"""Jobs as the engine sees them: a name, an outcome, and the events of a job's life."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path


class Outcome(Enum):
    FINISHED = "finished"
    UP_TO_DATE = "up to date"
    FAILED = "failed"
    SKIPPED = "skipped"
    INTERRUPTED = "interrupted"


@dataclass(frozen=True, slots=True)
class JobResult:
    """What one job came to. `package` names the job (in wsbuild's runs, a package)."""

    package: str
    outcome: Outcome
    seconds: float = 0.0
    message: str = ""
    log_dir: Path | None = None
    #: a shell line that reproduces the failed step by hand
    reproduce: str = ""
    warnings: tuple[str, ...] = field(default=())
    #: a script doing what `reproduce` does, shown instead of its long line
    reproduce_script: Path | None = None
    #: FINISHED by restoring a stored result (the build cache): nothing was built
    restored: bool = False


@dataclass(frozen=True, slots=True)
class JobStarted:
    """A package's job started."""

    package: str


@dataclass(frozen=True, slots=True)
class StepStarted:
    """A step of a package's job started."""

    package: str
    label: str


@dataclass(frozen=True, slots=True)
class JobFinished:
    """A package's job finished, with its result."""

    result: JobResult


JobEvent = JobStarted | StepStarted | JobFinished
