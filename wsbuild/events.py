"""Small typed events the work emits; the reporter decides what a user sees. A job's own events
(started, step started, finished) are the engine's (engine/jobs.py)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from wsbuild.engine.jobs import JobFinished, JobResult, JobStarted, Outcome, StepStarted


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
    """The run ended: each package's result, how long it took, the summary's last lines."""

    results: tuple[JobResult, ...]
    seconds: float
    verb: str = "build"
    #: lines the summary ends with (compiler cache counts, `--timings` table)
    details: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class Summary:
    """Closing lines a run composed itself (`wsbuild test`'s results), shown as they are."""

    lines: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class PlanMade:
    """A build's plan is made: `no_op` when it has nothing to restore or build and no refusal
    (the reporter tells the run's recorder, engine/recording.py, to keep watching or stop)."""

    no_op: bool


@dataclass(frozen=True, slots=True)
class NoOpFinished:
    """A build that was a no-op ended well: where its files are, and its time as its summary
    showed it (the recorder keeps it for the next run's replay)."""

    build_base: Path
    log_base: Path
    run_log: Path
    seconds: float


Event = (JobStarted | StepStarted | JobFinished | Notice | CacheRestored | RunFinished | Summary
         | PlanMade | NoOpFinished)
Emit = Callable[[Event], None]

#: the event types by name, and what they hold (a replayed run's record keeps its events)
_TYPES: dict[str, type] = {cls.__name__: cls for cls in (
    JobStarted, StepStarted, JobFinished, JobResult, Notice, CacheRestored, RunFinished,
    Summary)}


def event_to_data(value: object) -> object:
    """An event as JSON data (engine/replay.py draws a recorded run's events again)."""
    if type(value).__name__ in _TYPES and hasattr(value, "__dataclass_fields__"):
        return {"type": type(value).__name__,
                **{name: event_to_data(getattr(value, name))
                   for name in value.__dataclass_fields__}}  # type: ignore[attr-defined]
    if isinstance(value, Outcome):
        return {"__outcome__": value.value}
    if isinstance(value, Path):
        return {"__path__": str(value)}
    if isinstance(value, (tuple, list)):
        return [event_to_data(item) for item in value]
    return value


def event_from_data(data: object) -> object:
    """The event `event_to_data` made `data` of (ValueError: not one)."""
    if isinstance(data, list):
        return tuple(event_from_data(item) for item in data)
    if isinstance(data, dict):
        if "__outcome__" in data:
            return Outcome(data["__outcome__"])
        if "__path__" in data:
            return Path(data["__path__"])
        kind = _TYPES.get(str(data.get("type")))
        if kind is None:
            raise ValueError(f"not an event: {data!r}")
        return kind(**{k: event_from_data(v) for k, v in data.items() if k != "type"})
    return data

__all__ = ["CacheRestored", "Emit", "Event", "JobFinished", "JobResult", "JobStarted", "Notice",
           "RunFinished", "StepStarted", "Summary", "event_from_data", "event_to_data"]
