"""The recording of a run that lets the next run of the same command be replayed
(engine/replay.py).

`recording(argv)` holds a whole run of a replayed verb: it hears every input the run declares
(wsbuild/inputs.py: the paths it stats, the files it reads, the directories it lists, the
directories a program it starts searches) and keeps a copy of what the run prints through
its streams. It is handed down, never looked up: launch.py gives it to cli.py, which gives it
to the verb with the run's terminal (reporter.py's `Terminal`); a build's reporter tells it
what the run was (the pipeline's `PlanMade` and `NoOpFinished` events: `drop` as soon as the
plan has work, `no_op` at the end), a verb that only reads calls `read_only` when it is done.
Nothing is swapped in `sys.stdout`: a verb that is recorded writes through `stdout`/`stderr`
here. A recorder that fails says so in one warning, and the next run is a full one. At the
end of such a run, exiting 0, the recording is written: the declared paths and each declared
directory's entries, each with its signature. Nothing else: a read that was not declared is
not in the recording, which is why the test suite runs every recorded run under the oracle of
engine/inputs_oracle.py, which traces the process's own accesses and names any undeclared one.

A recording is only written when it can be trusted:
- It holds what the run saw of each path it stat'ed (a change after that read shows at the
  next replay) and, for files it read and the entries of directories it listed, their
  signatures at its end (a file read and gone by then spoils it). Nothing it looked at may
  have changed in the second before it started (the "racy" rule of git's index): a change in
  the same timestamp tick as the read would not show in a later stat. A path it could not
  read spoils it. Otherwise there is no recording, and the next run is full.
- The run's own outputs are not inputs: the log base, the workspace lock and the records.
- Options that do more than plan and build (`--install-deps` runs installers), print what
  differs from run to run (the CPU times of `--timings`) or select by test results (JUnit
  files) are never recorded.
"""

from __future__ import annotations

import io
import json
import os
import stat
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TextIO

from wsbuild import inputs
from wsbuild.engine.inputs_oracle import InputsOracle
from wsbuild.engine.replay import (
    ABSENT,
    FOLLOW,
    IDENTITY,
    RECORDINGS,
    RUN_LOG,
    replaced,
    STARTED,
    key_of,
    recording_path,
    signature,
)
from wsbuild.files import atomic_write, private_directory

#: a path changed this recently (ns) before the run started may have changed unseen
RACY_NS = 1_000_000_000
#: beside the records: why the last run left none
WHY_NOT = "not-recorded.txt"
NOT_RECORDED = frozenset({"--install-deps", "--timings",
                          # they read test results (JUnit files under build/): run in full
                          "--packages-select-test-failures", "--packages-skip-test-passed"})
#: what a no-op writes to its log directory (a replay writes the same)
LOG_FILES = frozenset({"up_to_date.log", "report.json", "timings.json", "timings.txt"})


class _Tee(io.TextIOBase):
    """A text stream that writes through to `stream` and keeps a copy."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.parts: list[str] = []
        self.keep = True
        #: a write failed (`wsbuild list | head -1`): the copy is not what the run printed
        self.failed = False

    def write(self, text: str) -> int:
        if self.keep:
            self.parts.append(text)
        try:
            return self.stream.write(text)
        except BaseException:
            self.failed = True
            raise

    def flush(self) -> None:
        try:
            self.stream.flush()
        except BaseException:
            self.failed = True
            raise

    def isatty(self) -> bool:
        return self.stream.isatty()

    def fileno(self) -> int:
        return self.stream.fileno()

    @property
    def encoding(self) -> str:  # type: ignore[override]
        return self.stream.encoding

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


#: what a run saw of a path it opened (its signature is taken at the end)
OPENED = (1,)
#: a path declared as an input (wsbuild/inputs.py): its signature at the end, absent or not
DECLARED = (2,)


class ReplayRecorder:
    """The paths a run looks at, from `install` until `finish` or `drop`."""

    def __init__(self, argv: Sequence[str]) -> None:
        self.verb = argv[0]
        self.key = key_of(argv)
        #: wsbuild never changes its working directory (it starts commands in others)
        self.cwd = os.getcwd()
        self.started_ns = time.time_ns()
        #: (absolute path, follows symlinks) -> what the run first saw: a signature (stat,
        #: lstat), ABSENT, or OPENED
        self.seen: dict[tuple[str, bool], tuple[int, ...]] = {}
        #: directories the run listed
        self.listed: set[str] = set()
        self.outcome: dict[str, str] | None = None
        self.active = False
        #: the run met something a recording could not describe (a path it could not read)
        self.spoiled = False
        #: what the recorded verb writes through (the process's streams, copied)
        self.stdout = _Tee(sys.stdout)
        self.stderr = _Tee(sys.stderr)
        self.finished = False
        #: what the reporter showed, in order (a build's recording draws it again)
        self._shown: list[list[object]] = []
        self._unlisten: Callable[[], None] | None = None
        #: the files wsbuild keeps for itself that the run read (`inputs.declare_memo`)
        self.memos: set[str] = set()
        #: why the run leaves no recording, once that is known (`_say_why_not`)
        self.why_not = ""
        #: the test suite's oracle (engine/inputs_oracle.py), when WSBUILD_INPUTS_ORACLE names
        #: its file: the process's own accesses traced, the undeclared ones written down
        self.oracle = InputsOracle.from_environment(self.cwd)

    def _declared(self, path: str, kind: str, seen: tuple[int, ...] | None) -> None:
        """An input declared through wsbuild/inputs.py."""
        if not self.active:
            return
        if kind in (inputs.UNREADABLE, inputs.UNRECORDED):
            # what the run made of it (unreadable: missing?) is unknown, or not all it read
            # is declared: no recording
            self.spoiled = True
            return
        name = self._absolute(path)
        if name is None:
            return
        if kind == inputs.MEMO:
            self.memos.add(name)
            return
        if kind == inputs.LISTING:
            self.listed.add(name)
        else:
            follow = kind != inputs.LSTAT
            saw = seen if seen is not None else OPENED if kind == inputs.FILE else DECLARED
            self.seen.setdefault((name, follow), saw)

    def _declared_many(self, heard: list[tuple[str, str, tuple[int, ...] | None]]) -> None:
        """`_declared` of each of `heard` (what `inputs.signatures` stat'ed by the thousand):
        an absolute path's signature noted at once, anything else as `_declared` does."""
        if not self.active:
            return
        seen = self.seen
        for path, kind, saw in heard:
            if saw is not None and path[:1] == "/" and (kind == inputs.STAT
                                                        or kind == inputs.LSTAT):
                seen.setdefault((path, kind == inputs.STAT), saw)
            else:
                self._declared(path, kind, saw)

    def no_op(self, *, build_base: Path, log_base: Path, run_log: Path, seconds: float) -> None:
        """The build was a no-op that ended well; `seconds` as its summary shows them."""
        self.outcome = {"build_base": str(build_base), "log_base": str(log_base),
                        "run_log": str(run_log), "seconds": f"{seconds:.2f}"}

    def shown(self, kind: str, data: object) -> None:
        """What the reporter showed (reporter.py): a build's replay shows it again through the
        reporter (`kind`: reporter, event, package_list, warnings, notes)."""
        if self.active:
            self._shown.append([kind, data])

    def read_only(self, *, build_base: Path) -> None:
        """The run only read, and printed all it did."""
        self.outcome = {"build_base": str(build_base)}

    def drop(self) -> None:
        """Not a no-op: stop watching, write nothing."""
        self.outcome = None
        self.stdout.keep = self.stderr.keep = False
        self.stdout.parts.clear()
        self.stderr.parts.clear()
        self._shown.clear()
        self._uninstall()

    def _absolute(self, path: object) -> str | None:
        """`path` as the key of what was seen (None: not a path, e.g. a descriptor). Not
        normalised: the run's paths are, and a path seen twice in two spellings is merely
        stat'ed twice by a replay."""
        if type(path) is not str:
            if not isinstance(path, (str, bytes, os.PathLike)):
                return None
            path = os.fsdecode(path)
        return path if path[:1] == "/" else os.path.join(self.cwd, path)  # type: ignore[index]

    def install(self) -> None:
        self._unlisten = inputs.listen(self._declared, many=self._declared_many)
        self.active = True
        if self.oracle is not None:
            self.oracle.install()

    def _uninstall(self) -> None:
        self.active = False
        if self._unlisten is not None:
            self._unlisten()
            self._unlisten = None
        if self.oracle is not None:
            self.oracle.uninstall()

    def finish(self, exit_code: int) -> None:
        """At the end of the run: the recording, if the run was a no-op that can be trusted."""
        self._uninstall()
        self.finished = True
        try:
            self._write(exit_code)
        except Exception as exc:  # noqa: BLE001 - a recording is never worth failing the run
            # said, not swallowed: the run stands, the next one is a full one
            print(f"wsbuild: warning: this run was not kept for replaying the next one "
                  f"({type(exc).__name__}: {exc}); the next run is a full one",
                  file=self.stderr.stream)
        if self.oracle is not None and self.outcome is not None and exit_code == 0 \
                and not self.spoiled:  # (a spoiled run leaves no recording)
            outputs = (self.outcome.get("log_base", ""), str(RECORDINGS.absolute()),
                       os.path.join(self.outcome["build_base"], ".wsbuild.build.lock"),
                       *sorted(self.memos))
            self.oracle.report_undeclared(self.seen, self.listed, outputs)

    def _write(self, exit_code: int) -> None:
        outcome = self.outcome
        if exit_code != 0 or outcome is None or self.spoiled or self.stdout.failed \
                or self.stderr.failed:
            return
        if os.path.abspath(RECORDINGS.parent.parent) != outcome["build_base"]:
            return  # a replay looks for the recording under ./build only
        self.why_not = ""
        inputs = self._paths(outcome)
        if "run_log" in outcome:  # a build: what its reporter showed, drawn again
            log = _log_of(Path(outcome["run_log"]), outcome["log_base"])
            stdout = stderr = ""
            shown = replaced(self._shown, outcome["run_log"], RUN_LOG)
        else:  # list, graph, info: what they printed
            log = shown = None
            stdout, stderr = "".join(self.stdout.parts), "".join(self.stderr.parts)
        if inputs is None or log is None and "run_log" in outcome:
            self._say_why_not(self.why_not or "its log directory holds what a replay cannot "
                              "write again")
            return
        recording = {"key": self.key, "build_base": outcome["build_base"], "paths": inputs[0],
                  "digest": inputs[1], "stdout": stdout, "stderr": stderr, "shown": shown,
                  "log": log}

        try:
            private_directory(RECORDINGS.parent)
            private_directory(RECORDINGS)
            atomic_write(recording_path(self.verb).absolute(),
                         json.dumps(recording, separators=(",", ":")), mode=0o600)
        except OSError as exc:  # a full disk, a read-only build base: the next run is full
            raise OSError(f"writing {recording_path(self.verb)}: {exc.strerror or exc}") from exc
        (RECORDINGS / WHY_NOT).absolute().unlink(missing_ok=True)

    def _say_why_not(self, why: str) -> None:
        """Why this run left no recording (the next is a full one too), beside the recordings, for
        whoever wonders why a no-op was not replayed: a path, never a value."""
        try:
            private_directory(RECORDINGS.parent)
            private_directory(RECORDINGS)
            atomic_write((RECORDINGS / WHY_NOT).absolute(), f"{self.verb}: {why}\n", mode=0o600)
        except OSError:
            pass  # only an explanation

    def _paths(self, outcome: dict[str, str]) -> tuple[list[list[object]], int] | None:
        """Every path the run looked at and each listed directory's entries that are not
        directories, grouped by directory, with how to look at them again (replay.signature)
        and the digest of their signatures: what the run saw where it stat'ed them, else
        their signatures now; None when an opened file is gone, or a path changed too
        recently to trust."""
        outputs = tuple(path + os.sep for path in (outcome.get("log_base"),
                                                   str(RECORDINGS.absolute())) if path)
        lock = os.path.join(outcome["build_base"], ".wsbuild.build.lock")
        wanted: dict[tuple[str, bool], tuple[int, ...] | None] = dict(self.seen)
        # wsbuild's own code that ran: another build of it (an upgrade that kept the version
        # number, an edit of an editable install) may answer otherwise
        for name, module in list(sys.modules.items()):
            file = getattr(module, "__file__", None)
            if file and (name == "wsbuild" or name.startswith("wsbuild.")):
                wanted.setdefault((file, True), None)
        for directory in sorted(self.listed):  # (a set: the same recording for the same run)
            wanted.setdefault((directory, True), None)
            try:
                entries = list(os.scandir(directory))
            except OSError:
                continue
            for entry in entries:
                if not entry.is_dir(follow_symlinks=False):
                    wanted.setdefault((entry.path, False), None)
                if entry.is_symlink():  # where it points, and what is there (or is not)
                    wanted.setdefault((entry.path, True), None)
        racy = self.started_ns - RACY_NS
        output_dirs = tuple(path[:-1] for path in outputs)  # (the directories themselves)
        listed = self.listed
        grouped: dict[str, list[tuple[str, int, tuple[int, ...]]]] = {}
        # (a loop over every path the run looked at, thousands: written for speed)
        for (path, follow), saw in wanted.items():
            if path.startswith(outputs) or path == lock or path in output_dirs:
                continue
            how = FOLLOW if follow else 0
            # a stat's result is what the run decided on; a later change shows at replay
            now = signature(path, how) if saw is None or saw is OPENED or saw is DECLARED \
                else saw
            if saw is OPENED and now == ABSENT:
                self.why_not = f"{path} was deleted while it ran"
                return None
            if not follow and stat.S_ISDIR(now[0]) and path not in listed:
                how |= IDENTITY
                now = now[:2]
            elif len(now) > 3 and (now[3] >= racy or now[4] >= racy):
                self.why_not = (f"{path} changed {(self.started_ns - max(now[3:])) / 1e9:.2f} s "
                                "before it started (or later): too recently to trust")
                return None
            directory, _, name = path.rpartition("/")
            if not name or not directory:  # "/" and the directories right under it
                directory, name = path, ""
            group = grouped.get(directory)
            if group is None:
                group = grouped[directory] = []
            group.append((name, how, now))
        paths: list[list[object]] = [[d, [n for n, _, _ in e], [h for _, h, _ in e]]
                                     for d, e in grouped.items()]
        # the digest of these very signatures (in replay.digest's order): stat'ing again could
        # see a change made after the checks above
        return paths, hash(tuple(sig for e in grouped.values() for _, _, sig in e))


def _log_of(run_log: Path, log_base: str) -> dict[str, object] | None:
    """What the recorded run wrote to its log directory that a replay writes again: the
    same files, with its start time made a blank (None: something else is there)."""
    try:
        names = set(os.listdir(run_log))
        if names - LOG_FILES or "timings.json" not in names:
            return None
        up_to_date = (run_log / "up_to_date.log").read_text() if "up_to_date.log" in names \
            else ""
        timings = json.loads((run_log / "timings.json").read_text())
        lines = (run_log / "timings.txt").read_text().splitlines()
        report = (run_log / "report.json").read_text(encoding="utf-8") \
            if "report.json" in names else None
    except (OSError, ValueError):
        return None
    if "" not in lines or not isinstance(timings, dict) or "cores" not in timings:
        return None
    if report is not None:
        started = json.loads(report).get("started")
        if not started or report.count(json.dumps(started)) != 1:
            return None
        report = report.replace(json.dumps(started), STARTED)
    return {"log_base": log_base, "up_to_date": up_to_date, "report": report,
            "timings": timings, "table": lines[:lines.index("")]}


@contextmanager
def recording(argv: Sequence[str]) -> Iterator[ReplayRecorder | None]:
    """Watch the run of `argv` (a replayed verb's): the recorder, to hand down to the run and
    to `finish` with its exit code (a run that raised is finished as failed); None when such
    a command line is never recorded."""
    if any(arg.split("=")[0] in NOT_RECORDED for arg in argv):
        yield None
        return
    watcher = ReplayRecorder(argv)
    watcher.install()
    try:
        yield watcher
    finally:
        if not watcher.finished:
            watcher.finish(1)
