"""The one reporter: turns events into console lines, a live status line on a terminal, and the summary.

The status line (terminal only) reads `[9.1s] [3/7 done, ~12 s left] [=====>    ] [pkg:build - 0.4s] …`:
packages done of all, the time left estimated from recorded durations and the critical path
(engine/progress.py; none on a first build), a progress bar, then what is running.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from wsbuild.events import (
    CacheRestored,
    Event,
    JobFinished,
    JobStarted,
    NoOpFinished,
    Notice,
    PlanMade,
    RunFinished,
    StepStarted,
    Summary,
    event_from_data,
    event_to_data,
)
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.engine.progress import Progress
from wsbuild.engine.replay import replaced
from wsbuild.words import plural

TYPE_CHECKING = False  # (typing is not imported on a replay: 3 ms)
if TYPE_CHECKING:
    from typing import TextIO

    from wsbuild.engine.recording import ReplayRecorder

#: characters of the status line's progress bar
BAR_WIDTH = 20


@dataclass(frozen=True)
class Terminal:
    """Where a run's words go: its standard output and error, and (a run of a verb that can be
    replayed) the recorder that keeps what was shown, so that a no-op's replay
    (engine/replay.py) shows the same through the same functions. cli.py makes it and hands it
    to the verb; nothing looks it up."""

    stdout: TextIO
    stderr: TextIO
    recorder: ReplayRecorder | None = None

    @classmethod
    def of(cls, recorder: ReplayRecorder | None) -> Terminal:
        """The process's streams, through `recorder`'s copies when there is one."""
        if recorder is None:
            return cls(sys.stdout, sys.stderr)
        return cls(recorder.stdout, recorder.stderr, recorder)  # type: ignore[arg-type]

    def warnings(self, warnings: Iterable[str]) -> None:
        warnings = list(warnings)
        if warnings and self.recorder is not None:
            self.recorder.shown("warnings", warnings)
        print_warnings(warnings, self.stderr)

    def notes(self, notes: Iterable[str]) -> None:
        notes = list(notes)
        if notes and self.recorder is not None:
            self.recorder.shown("notes", notes)
        print_notes(notes, self.stderr)


def _near(path: Path) -> str:
    """`path` relative to the working directory when it is below it (`build/pkg/x.sh`)."""
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


class ReplayDrawing:
    """What a recorded no-op build showed, shown again through the same functions: its
    warnings and notes, its reporter (same console options) and the reporter's events, the
    summary with the replay's own time (engine/replay.py's `Drawing`)."""

    KINDS = ("reporter", "event", "package_list", "warnings", "notes")

    def decode(self, shown: list[list[object]]) -> list[tuple[str, object]]:
        calls = []
        for kind, data in shown:
            if kind not in self.KINDS:
                raise ValueError(kind)
            calls.append((str(kind), event_from_data(data) if kind == "event" else data))
        return calls

    def draw(self, shown: list[list[object]], blank: str, run_log: str,
             started: float) -> None:
        from dataclasses import replace

        reporter = None
        try:
            for kind, data in self.decode(replaced(shown, blank, run_log)):
                if kind == "warnings":
                    print_warnings(data)  # type: ignore[arg-type]
                elif kind == "notes":
                    print_notes(data)  # type: ignore[arg-type]
                elif kind == "reporter":
                    assert isinstance(data, dict)
                    reporter = Reporter(verb=data["verb"], console=Console(**data["console"]))
                elif kind == "package_list" and reporter is not None:
                    pairs = data  # [[name, build type], ...]
                    reporter.package_list([(str(n), str(t)) for n, t in pairs])  # type: ignore
                elif kind == "event" and reporter is not None:
                    if isinstance(data, RunFinished):
                        data = replace(data, seconds=time.monotonic() - started)
                    reporter(data)  # type: ignore[arg-type]
            if reporter is not None:
                reporter.stop()
            sys.stdout.flush()
        except BrokenPipeError:  # a reader that went away (`| head -1`), as in cli.py
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def print_warnings(warnings: Iterable[str], stream: TextIO | None = None) -> None:
    """Warnings found before a run starts (discovery, result files), one line each on stderr."""
    for warning in warnings:
        print(f"wsbuild: warning: {warning}", file=stream or sys.stderr)


def print_notes(notes: Iterable[str], stream: TextIO | None = None) -> None:
    """Notes on how a command line was understood (an option ignored, and why), on stderr."""
    for note in notes:
        print(f"wsbuild: note: {note}", file=stream or sys.stderr)


def _duration(seconds: float) -> str:
    """`~12 s`, `~3 min`: an estimate's precision (`<1 s` once the estimate is used up)."""
    if seconds < 1:
        return "<1 s"
    if seconds < 100:
        return f"~{seconds:.0f} s"
    return f"~{seconds / 60:.0f} min"


@dataclass(frozen=True, slots=True)
class Console:
    """What the console shows besides the defaults (colcon's event handlers, verbs/colcon.py)."""

    #: every step's output as it is written (console_direct+), read from the packages' logs
    direct: bool = False
    #: each package's output in one block when it finishes (console_cohesion+)
    cohesion: bool = False
    #: the packages in order before the run (console_package_list+)
    package_list: bool = False
    #: Starting >>> / Finished <<< lines (console_start_end)
    start_end: bool = True
    #: each package's warnings when it finishes (console_stderr)
    stderr: bool = True
    summary: bool = True
    #: the live status line: None on a terminal only, False never (status-)
    status: bool | None = None


_OUTPUT_LOG = "stdout_stderr.log"


@dataclass(slots=True)
class _Tail:
    """console_direct+: a running package's output log and how much of it is shown."""

    path: Path
    shown: int = 0


class Reporter:
    """Console output for a run. Thread-safe: events arrive from worker threads."""

    def __init__(self, stream: TextIO | None = None, *, live: bool | None = None,
                 verb: str = "build", console: Console | None = None,
                 log_base: Path | None = None, progress: Progress | None = None,
                 recorder: ReplayRecorder | None = None) -> None:
        self.stream = stream or sys.stdout
        #: the run's recorder (a build that may be replayed): what this reporter shows, and
        #: whether the run was a no-op
        self.recorder = recorder
        self.console = console or Console()
        if live is None:
            live = self.stream.isatty() and self.console.status is not False
        self.live = live
        self.verb = verb
        #: console_direct+: package → (its output log, how much of it is shown)
        self._log_base = log_base
        self._tails: dict[str, _Tail] = {}
        self._tailer: threading.Thread | None = None
        self._lock = threading.Lock()
        self._running: dict[str, tuple[float, str]] = {}
        self._finished = 0
        self._done: set[str] = set()
        #: the run's packages, dependencies and recorded durations: "3/7 done, ~12 s left"
        self.progress = progress
        #: packages installed from the build cache (their JobFinished says FINISHED)
        self._restored: set[str] = set()
        self._status_shown = False
        self._start = time.monotonic()
        self._ticker: threading.Thread | None = None
        self._stop = threading.Event()
        if recorder is not None:
            recorder.shown("reporter", {"verb": verb, "console": asdict(self.console)})

    def __call__(self, event: Event) -> None:
        if isinstance(event, (PlanMade, NoOpFinished)):
            self._tell_recorder(event)
            return
        if self.recorder is not None:
            self.recorder.shown("event", event_to_data(event))
        with self._lock:
            self._clear_status()
            self._handle(event)
            self._draw_status()

    def _tell_recorder(self, event: PlanMade | NoOpFinished) -> None:
        """What the run was, for its recorder: a plan with work stops it (nothing of this run
        is kept), a no-op that ended well is kept for the next run's replay."""
        if self.recorder is None:
            return
        if isinstance(event, PlanMade):
            if not event.no_op:
                self.recorder.drop()
        else:
            self.recorder.no_op(build_base=event.build_base, log_base=event.log_base,
                                run_log=event.run_log, seconds=event.seconds)

    def start_ticker(self) -> None:
        if self.live and self._ticker is None:
            self._ticker = threading.Thread(target=self._tick, daemon=True)
            self._ticker.start()
        if self.console.direct and self._log_base is not None and self._tailer is None:
            self._tailer = threading.Thread(target=self._tail, daemon=True)
            self._tailer.start()

    def stop(self) -> None:
        self._stop.set()
        if self._tailer is not None:
            self._tailer.join()
        with self._lock:
            self._clear_status()

    def package_list(self, packages: Sequence[tuple[str, str]]) -> None:
        """console_package_list+: the packages (name, build type) in the order they run."""
        if self.recorder is not None:
            self.recorder.shown("package_list", [list(p) for p in packages])
        if self.console.package_list and packages:
            with self._lock:
                self._write("Topological order")
                for name, build_type in packages:
                    self._write(f"- {name} ({build_type})")

    def _tail(self) -> None:
        while not self._stop.wait(0.1):
            with self._lock:
                for name in list(self._tails):
                    self._show_new_output(name, final=False)

    def _show_new_output(self, name: str, *, final: bool) -> None:
        """console_direct+: what the package's output log gained since the last look."""
        tail = self._tails[name]
        try:
            with open(tail.path, "rb") as handle:
                handle.seek(tail.shown)
                data = handle.read()
        except OSError:
            return
        if not final:
            data = data[: data.rfind(b"\n") + 1]  # whole lines only while the step runs
        if data:
            self._clear_status()
            self.stream.write(data.decode(errors="replace"))
            if not data.endswith(b"\n"):
                self.stream.write("\n")
            self.stream.flush()
            tail.shown += len(data)

    def _tick(self) -> None:
        while not self._stop.wait(1.0):
            with self._lock:
                self._clear_status()
                self._draw_status()

    def _write(self, text: str) -> None:
        self.stream.write(text + "\n")
        self.stream.flush()

    def _handle(self, event: Event) -> None:
        if isinstance(event, JobStarted):
            self._running[event.package] = (time.monotonic(), "")
        elif isinstance(event, StepStarted):
            # "Starting" waits for the first step: up-to-date packages never take one
            started, label = self._running.get(event.package, (time.monotonic(), ""))
            if not label:
                if self.console.start_end:
                    self._write(f"Starting >>> {event.package}")
                self._follow(event.package)
            self._running[event.package] = (started, event.label)
        elif isinstance(event, JobFinished):
            self._running.pop(event.result.package, None)
            if event.result.package in self._tails:
                self._show_new_output(event.result.package, final=True)
                del self._tails[event.result.package]
            self._finished += 1
            self._done.add(event.result.package)
            self._finished_lines(event.result)
        elif isinstance(event, CacheRestored):
            self._restored.add(event.package)
        elif isinstance(event, Notice):
            prefix = "WARNING: " if event.warning else ""
            where = f"[{event.package}] " if event.package else ""
            self._write(f"{prefix}{where}{event.text}")
        elif isinstance(event, RunFinished):
            self._summary(event)
        elif isinstance(event, Summary):
            for line in event.lines:
                self._write(line)

    def _follow(self, name: str) -> None:
        """console_direct+: show the output log of the package the run just started."""
        if not self.console.direct or self._log_base is None:
            return
        run = (self._log_base / f"latest_{self.verb}").resolve()
        self._tails[name] = _Tail(run / name / _OUTPUT_LOG)

    def _cohesion_block(self, result: JobResult) -> None:
        """console_cohesion+: the package's whole output, in one block."""
        if result.log_dir is None:
            return
        try:
            text = (result.log_dir / _OUTPUT_LOG).read_text(errors="replace")
        except OSError:
            return
        if text:
            self._write(f"--- output: {result.package}\n{text.rstrip()}\n---")

    def _finished_lines(self, result: JobResult) -> None:
        name = result.package
        if self.console.cohesion and result.outcome is not Outcome.UP_TO_DATE:
            self._cohesion_block(result)
        if result.warnings and self.console.stderr:
            self._write(f"--- warnings: {name}")
            for warning in result.warnings:
                self._write(warning)
            self._write("---")
        if result.outcome is Outcome.FINISHED and not self.console.start_end:
            pass  # console_start_end-
        elif result.outcome is Outcome.FINISHED and name in self._restored:
            self._write(f"Restored <<< {name} [{result.seconds:.2f}s] from cache")
        elif result.outcome is Outcome.FINISHED:
            self._write(f"Finished <<< {name} [{result.seconds:.2f}s]")
        elif result.outcome is Outcome.UP_TO_DATE:
            pass  # counted in the summary; the package's log says why
        elif result.outcome is Outcome.FAILED:
            self._write(f"Failed   <<< {name} [{result.seconds:.2f}s] {result.message}".rstrip())
            if result.log_dir is not None:
                self._write(f"  log: {result.log_dir}")
            if result.reproduce_script is not None:
                # the line itself (its environment: ~2,000 characters) is in the log
                self._write("  reproduce by hand:")
                self._write(f"    {_near(result.reproduce_script)}   # the step's directory, "
                            "environment and command")
            elif result.reproduce:
                self._write("  reproduce by hand:")
                for line in result.reproduce.splitlines():
                    self._write(f"    {line}")
        elif result.outcome is Outcome.INTERRUPTED:
            self._write(f"Aborted  <<< {name} [{result.seconds:.2f}s]")

    def _summary(self, event: RunFinished) -> None:
        if not self.console.summary:
            return
        by_outcome: dict[Outcome, list[str]] = {}
        for result in event.results:
            by_outcome.setdefault(result.outcome, []).append(result.package)
        verb_done = "finished"
        lines = [f"Summary: {plural(len(by_outcome.get(Outcome.FINISHED, [])), 'package')} "
                 f"{verb_done} [{event.seconds:.2f}s]"]
        restored = [n for n in by_outcome.get(Outcome.FINISHED, []) if n in self._restored]
        if restored:
            lines.append(f"  {plural(len(restored), 'package')} restored from cache")
        labels = (
            (Outcome.UP_TO_DATE, "up to date"),
            (Outcome.FAILED, "failed"),
            (Outcome.INTERRUPTED, "aborted"),
            (Outcome.SKIPPED, "not processed"),
        )
        for outcome, label in labels:
            names = by_outcome.get(outcome, [])
            if names:
                shown = ": " + " ".join(names) if outcome is not Outcome.UP_TO_DATE else ""
                lines.append(f"  {plural(len(names), 'package')} {label}{shown}")
        warned = [r.package for r in event.results if r.warnings]
        if warned:
            lines.append(f"  {plural(len(warned), 'package')} had warnings: {' '.join(warned)}")
        lines += [f"  {line}" for line in event.details]
        for line in lines:
            self._write(line)

    def _status_text(self) -> str:
        now = time.monotonic()
        parts = [f"[{now - self._start:.1f}s]", *self._progress_parts(now)]
        for name, (started, label) in sorted(self._running.items()):
            step = f":{label}" if label else ""
            parts.append(f"[{name}{step} - {now - started:.1f}s]")
        return " ".join(parts)

    def _progress_parts(self, now: float) -> list[str]:
        """`[3/7 done, ~12 s left]` and the bar; `[3 done]` without a plan of the run."""
        if self.progress is None or not self.progress.total:
            return [f"[{self._finished} done]"]
        total = self.progress.total
        done = min(self._finished, total)
        running = {name: now - started for name, (started, _) in self._running.items()}
        left = self.progress.seconds_left(self._done, running)
        estimate = f", {_duration(left)} left" if left is not None else ""
        filled = BAR_WIDTH * done // total
        bar = "=" * filled + (">" if filled < BAR_WIDTH else "") + " " * (BAR_WIDTH - filled - 1)
        return [f"[{done}/{total} done{estimate}]", f"[{bar[:BAR_WIDTH]}]"]

    def _draw_status(self) -> None:
        if self.live and self._running:
            self.stream.write("\r" + self._status_text()[:200] + "\x1b[K")
            self.stream.flush()
            self._status_shown = True

    def _clear_status(self) -> None:
        if self._status_shown:
            self.stream.write("\r\x1b[K")
            self._status_shown = False
