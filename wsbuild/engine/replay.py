"""A command whose inputs did not change, answered from the recording of its last run.

`wsbuild build` when its plan finds every package up to date, and `list`, `graph` and `info`,
which only read, record while they run every input they declare (wsbuild/inputs.py: the paths
they stat, the files they read, the directories they or the programs they start search) and
keep those paths' stat signatures with digests of the command line and the environment (never
their values), the working directory, the terminal, what they showed and (a build) what they
wrote to its log directory: `build/.wsbuild/noop/<verb>.json`, readable by its owner only
(engine/recording.py).

The next run of the same command line, in the same directory, environment and terminal, stats
those paths again (`replay`, here; a build first takes the workspace lock). When every one is
as recorded, the full run would read the same files and so show the same: a build's reporter
(reporter.py) draws the events the recorded one drew, with this run's time, and the run writes a
log directory with the same files and its own times; `list`, `graph` and `info` print what the
recorded run printed — without parsing, scanning or planning anything. Anything else (a path
changed, another build holding the lock, no recording) goes down the full path, which records
anew. This module imports nothing a replay does not use.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

from wsbuild import __version__
from wsbuild.hashes import blake2b
from wsbuild.record.environment import environment_digests, environment_reason
from wsbuild.signature import stat_signature
from wsbuild.terminal import is_per_tab

TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Callable, Sequence
    from typing import Any, Protocol

    class Drawing(Protocol):
        """How a build's recorded reporter calls are shown again (reporter.py: `ReplayDrawing`)."""

        def decode(self, shown: Any) -> Any:
            """The calls, their events decoded (ValueError: not a recording this version wrote)."""
            ...

        def draw(self, shown: Any, blank: str, run_log: str, started: float) -> None:
            """Make the recorded calls, `blank` in their text replaced by `run_log`, the
            summary's time counted from `started`."""
            ...


#: relative to the working directory: under the default build base of a run started at the
#: workspace root, one recording per verb
RECORDINGS = Path("build") / ".wsbuild" / "noop"
#: the verbs that are replayed: build (a no-op), and those that only read
VERBS = frozenset({"build", "list", "graph", "info"})
FORMAT = 9
#: what a recording keeps in place of the run's log directory
RUN_LOG = "\0run_log\0"
#: report.json's start time, as the recording keeps it (a JSON string)
STARTED = '"@@wsbuild-started@@"'


#: the signature of a path that does not exist
ABSENT = (0, 0, 0, 0, 0)
#: how a path is looked at: follow symlinks (stat, not lstat); only its type and inode count
#: (a directory only lstat'ed, as realpath does with each ancestor of a path: its entries are
#: recorded one by one where they matter, and its times change with every file made in it)
FOLLOW, IDENTITY = 1, 2


def signature(path: str, how: int) -> tuple[int, ...]:
    """What a change to `path` changes: type and mode, inode, size, modification and change
    times (with IDENTITY: type, mode and inode); ABSENT when it does not exist."""
    try:
        st = os.stat(path) if how & FOLLOW else os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return ABSENT
    except OSError as exc:  # a symlink loop, a path that cannot be read: unlike any recording
        return (-1, exc.errno or 0)
    if how & IDENTITY:
        return (st.st_mode, st.st_ino)
    return stat_signature(st)


def digest(paths: list[list[Any]]) -> int:
    """One number for the signatures of `paths` ([directory, [name, ...], [how, ...]]; the
    name "" is the directory itself), in their order: a change to any path changes it. (The
    hash of a tuple of integers is the same in every process of one Python version; the
    recording's key holds the version.)"""
    # signature() and stat_signature(), inlined: this loop is most of a replay (40,000 paths
    # for 1,000 packages), and a call per path costs a tenth of it
    stat, lstat = os.stat, os.lstat
    signatures: list[tuple[int, ...]] = []
    add = signatures.append
    for directory, names, hows in paths:
        for name, how in zip(names, hows):
            path = f"{directory}/{name}" if name else directory
            try:
                st = stat(path) if how & FOLLOW else lstat(path)
            except (FileNotFoundError, NotADirectoryError):
                add(ABSENT)
                continue
            except OSError as exc:  # as signature() says
                add((-1, exc.errno or 0))
                continue
            if how & IDENTITY:
                add((st.st_mode, st.st_ino))
            else:
                add((st.st_mode, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns))
    return hash(tuple(signatures))


def key_of(argv: Sequence[str]) -> dict[str, object]:
    """Everything besides files that a build's plan and its console output depend on."""
    tty = [sys.stdout.isatty(), sys.stderr.isatty()]
    columns = os.get_terminal_size(sys.stdout.fileno()).columns if tty[0] else 0
    return {
        "format": FORMAT,
        # a digest: a command line may carry a credential (--cache http://user:token@host/)
        "argv": _digest("\0".join(argv)),
        "cwd": os.getcwd(),
        "environ": _environ(),
        "python": [sys.executable, sys.version],
        "wsbuild": __version__,
        "terminal": [*tty, columns],
    }


def _environ() -> dict[str, str]:
    """The environment by the digest of each variable (record/environment.py's rule, as a
    package record compares the variables its steps read: LD_LIBRARY_PATH as a set of
    directories; no value is ever written to the recording, a token in the environment stays
    out of build/), less what names the terminal tab, window or command (terminal.py: no step
    gets it, wsbuild reads none of it)."""
    return environment_digests(os.environ, leave_out=is_per_tab)


def _digest(text: str) -> str:
    return blake2b(text.encode("utf-8", "surrogateescape"), digest_size=32).hexdigest()


def recording_path(verb: str) -> Path:
    return RECORDINGS / f"{verb}.json"


def replay(argv: Sequence[str], drawing: Callable[[], Drawing]) -> int | None:
    """Answer `wsbuild <argv>` from its recording, or None: run it in full. `drawing` makes what
    shows a build's recorded reporter calls again (reporter.py's, handed down by launch.py:
    this room imports nothing above it)."""
    recording = _read_recording(argv)
    if recording is None:
        return None
    started = time.monotonic()
    if recording["log"] is None:  # a verb that only reads
        if not _unchanged(recording):
            return None
        _print(recording)
        return 0
    from wsbuild.engine.lock import workspace_lock  # lazy: off a replayed `list` and `list`
    from wsbuild.errors import WorkspaceError  # lazy: off a replayed `list`

    shown = recording["shown"]
    try:
        drawer = drawing()
        drawer.decode(shown)
    except (TypeError, ValueError, KeyError):
        return None  # not a recording this version wrote
    lock = workspace_lock(Path(recording["build_base"]), wait=False, on_wait=lambda _: None)
    try:
        lock.__enter__()
    except (WorkspaceError, OSError):  # busy, or unwritable: the full run says what is wrong
        return None
    try:
        if not _unchanged(recording):
            return None
        try:
            run_log = _write_log(recording["log"], started)
        except OSError:
            return None  # the full run says what is wrong (a full disk, a read-only log/)
        drawer.draw(shown, RUN_LOG, str(run_log), started)
        return 0
    finally:
        lock.__exit__(None, None, None)


def replaced(data: Any, old: str, new: str) -> Any:
    """`data` (JSON values) with `old` replaced by `new` in every string. Of a list, an item
    whose JSON text does not hold `old` (escaped as JSON escapes it, character by character)
    holds no string with it either: it is kept as it is, not walked (a build's recording of
    1,000 packages has a result for each, and the run's log path is in a few lines only)."""
    if isinstance(data, list):
        escaped, encode = json.dumps(old)[1:-1], json.JSONEncoder().encode
        if escaped not in encode(data):  # (most recordings: the log path is in none)
            return data
        return [_replaced(item, old, new) if escaped in encode(item) else item
                for item in data]
    return _replaced(data, old, new)


def _replaced(data: Any, old: str, new: str) -> Any:
    if isinstance(data, str):
        return data.replace(old, new)
    if isinstance(data, list):
        return [_replaced(item, old, new) for item in data]
    if isinstance(data, dict):
        return {key: _replaced(value, old, new) for key, value in data.items()}
    return data


def _unchanged(recording: dict[str, Any]) -> bool:
    try:
        return digest(recording["paths"]) == recording["digest"]
    except (TypeError, ValueError):  # not a recording this version wrote
        return False


def _print(recording: dict[str, Any]) -> None:
    """What the recorded run printed. A reader that went away (`wsbuild list | head -1`) is
    no error, as in cli.py."""
    for stream, text in ((sys.stdout, recording["stdout"]), (sys.stderr, recording["stderr"])):
        try:
            stream.write(text)
            stream.flush()
        except BrokenPipeError:
            os.dup2(os.open(os.devnull, os.O_WRONLY), stream.fileno())


def _read_recording(argv: Sequence[str]) -> dict[str, Any] | None:
    """The recording, when there is one for this command line, directory and environment."""
    try:
        with open(recording_path(argv[0]), encoding="utf-8") as handle:
            recording = json.load(handle)
    except (OSError, ValueError):
        return None
    if not isinstance(recording, dict) or not isinstance(recording.get("key"), dict):
        return None
    key = key_of(argv)
    environ = key.pop("environ")
    if {k: v for k, v in recording["key"].items() if k != "environ"} != key:
        return None
    # the environment is asked as a record's variables are (record/environment.py)
    if environment_reason(recording["key"]["environ"], environ) is not None:
        return None
    log = recording.get("log")
    shapes = ((recording.get("paths"), list), (recording.get("digest"), int),
              (recording.get("stdout"), str), (recording.get("stderr"), str),
              (recording.get("build_base"), str), (log, (dict, type(None))),
              (recording.get("shown"), (list, type(None))))
    if not all(isinstance(value, kind) for value, kind in shapes):
        return None
    if log is not None and not (isinstance(log.get("timings"), dict)
                                and isinstance(log.get("table"), list)
                                and isinstance(log.get("log_base"), str)):
        return None
    return recording


def _write_log(log: dict[str, Any], started: float) -> Path:
    """The run's log directory, as the recorded run wrote it, with this run's times."""
    from wsbuild.engine.logs import new_run_log  # lazy: off a replayed `list` and `list`
    from wsbuild.engine.timing_files import (
        cpu_seconds,
        started_at,
        summary_line,
        totals_json,
        write_timing_files,
    )  # lazy: off a replayed `list` and `list`

    run_log = new_run_log(Path(log["log_base"]), "build")
    if log["up_to_date"]:
        (run_log / "up_to_date.log").write_text(log["up_to_date"])
    wall = time.monotonic() - started
    children, own = cpu_seconds()
    cores = log["timings"]["cores"]
    write_timing_files(run_log, {**log["timings"], **totals_json(wall, children, own, cores)},
                       [*log["table"], "", summary_line(wall, children, own, cores)])
    if log["report"] is not None:
        text = log["report"].replace(STARTED, json.dumps(started_at(started)))
        (run_log / "report.json").write_text(text, encoding="utf-8")
    return run_log
