"""How a build type's in-process step has the processes it asks of a warm helper observed
(`PackageContext.observe`; the builder's is observe/steps.py's `StepObservations`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Protocol


class StepObserver(Protocol):
    """The helper starts with the observer loaded and idle; each request writes into a
    directory of its own."""

    def helper_environment(self, env: Mapping[str, str], directory: Path) -> dict[str, str]:
        """The environment a warm helper process starts with, writing what it reads while it
        starts into `directory`."""
        ...

    def directory(self, label: str) -> Path:
        """A new directory for the processes of one request of step `label`."""
        ...

    def request_environment(self, env: Mapping[str, str], directory: Path) -> dict[str, str]:
        """`env` as the processes of one request run with it, writing into `directory`."""
        ...

    @property
    def tracing(self) -> bool:
        """Whether the test suite's build-step oracle traces the programs (`trace`)."""
        ...

    def trace(self, argv: Sequence[str], label: str, env: Mapping[str, str]
              ) -> tuple[Sequence[str], Mapping[str, str]] | None:
        """`argv` and `env` under the test suite's build-step oracle, when it is on (a helper
        so started serves one request); else None."""
        ...

    def add(self, label: str, directory: Path, env: Mapping[str, str]) -> None:
        """What the processes that wrote into `directory` read, for step `label`, which
        ran with `env`."""
        ...
