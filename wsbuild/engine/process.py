"""Run one command: its own process group, output streamed to log files and to a line callback;
Ctrl-C, SIGTERM and SIGHUP end every process wsbuild started and every process those started
in turn."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from wsbuild.redaction import redact_bytes

TYPE_CHECKING = False
if TYPE_CHECKING:
    import subprocess

#: how long the processes of a cancelled run get to stop after SIGTERM before SIGKILL
GRACE_SECONDS = 3.0
#: how long SIGKILL is repeated on what is left (a process forking while it is swept)
_KILL_SECONDS = 2.0
#: how often the sweep looks again
_POLL_SECONDS = 0.05
#: prctl(2) option: orphaned descendants are reparented to this process instead of init
_PR_SET_CHILD_SUBREAPER = 36


#: the job (a package) whose thread starts processes now: set by the scheduler's workers
_job = threading.local()


def start_processes_for(job: str | None) -> None:
    """The processes this thread starts from now on are `job`'s (the memory governor,
    engine/memory.py, measures them as that package's)."""
    _job.name = job


class ProcessRegistry:
    """Every child process group wsbuild started, so Ctrl-C can end all of them, and with
    them every descendant, whatever process group or session it moved to; and which job
    started each."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._running: dict[int, subprocess.Popen[bytes]] = {}
        self._owners: dict[int, str] = {}
        self.cancelled = threading.Event()
        #: a second Ctrl-C: SIGKILL at once instead of waiting out the grace period
        self.hurried = threading.Event()

    def add(self, proc: subprocess.Popen[bytes]) -> None:
        owner = getattr(_job, "name", None)
        with self._lock:
            self._running[proc.pid] = proc
            if owner:
                self._owners[proc.pid] = owner
        if self.cancelled.is_set():
            _signal_group(proc.pid, signal.SIGKILL if self.hurried.is_set() else signal.SIGTERM)

    def remove(self, proc: subprocess.Popen[bytes]) -> None:
        with self._lock:
            self._running.pop(proc.pid, None)
            self._owners.pop(proc.pid, None)

    def owners(self) -> dict[int, str]:
        """The first process of each running step → the job that started it."""
        with self._lock:
            return dict(self._owners)

    def hurry(self) -> None:
        """Cut the grace period of `terminate_all` short (safe to call from a signal handler)."""
        self.hurried.set()

    def _leaders_exited(self, pgids: Sequence[int]) -> bool:
        """Whether the processes that lead `pgids` exited (where /proc is missing, the only
        sign left that a group stopped)."""
        with self._lock:
            procs = [self._running[pgid] for pgid in pgids if pgid in self._running]
        return all(proc.poll() is not None for proc in procs)

    def terminate_all(self) -> None:
        """SIGTERM every process group and every descendant (SIGCONT too: a stopped process
        cannot act on SIGTERM), then SIGKILL what is still alive after `GRACE_SECONDS`, or at
        once after `hurry()`. Returns when no descendant is alive, at most `_KILL_SECONDS`
        after the SIGKILL."""
        self.cancelled.set()
        with self._lock:
            groups = list(self._running)
        for pgid in groups:
            _signal_group(pgid, signal.SIGTERM)
        warned: set[int] = set()
        deadline = time.monotonic() + GRACE_SECONDS
        while not self.hurried.is_set() and time.monotonic() < deadline:
            alive = set(living_descendants())
            for pid in sorted(alive - warned):
                _signal_process(pid, signal.SIGTERM)
                _signal_process(pid, signal.SIGCONT)
            warned |= alive
            if not alive and self._leaders_exited(groups):
                return
            time.sleep(_POLL_SECONDS)
        with self._lock:
            groups = sorted(set(groups) | set(self._running))
        deadline = time.monotonic() + _KILL_SECONDS
        while True:
            for pgid in groups:
                # the group may outlive its leader: kill it regardless
                _signal_group(pgid, signal.SIGKILL)
            alive = living_descendants()
            for pid in alive:
                _signal_process(pid, signal.SIGKILL)
            if not alive or time.monotonic() >= deadline:
                return
            time.sleep(_POLL_SECONDS / 5)


def adopt_orphans() -> bool:
    """Make this process the child subreaper of everything it starts (Linux): a descendant
    whose parent exits (a daemon, a build step its Ninja left behind) is reparented to wsbuild
    instead of init, so `living_descendants()` still finds it. False where the system has no
    such thing; Ctrl-C then reaches only descendants whose parents are still alive."""
    if not sys.platform.startswith("linux"):
        return False
    import ctypes  # (3 ms to import: only a run that starts processes needs it)

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def living_descendants(root: int | None = None) -> list[int]:
    """The processes below `root` (default: this one) that have not exited, from /proc
    (empty where there is none). A zombie counts as exited: it holds nothing but its pid."""
    root = os.getpid() if root is None else root
    children: dict[int, list[int]] = {}
    exited: set[int] = set()
    for pid, _name, fields in _processes():
        if len(fields) < 2:
            continue
        children.setdefault(int(fields[1]), []).append(pid)
        if fields[0] in (b"Z", b"X"):
            exited.add(pid)
    found: list[int] = []
    stack = list(children.get(root, ()))
    while stack:
        pid = stack.pop()
        if pid not in exited:
            found.append(pid)
        stack.extend(children.get(pid, ()))
    return sorted(found)


def _signal_process(pid: int, sig: int) -> None:
    try:
        os.kill(pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def _signal_group(pgid: int, sig: int) -> None:
    try:
        os.killpg(pgid, sig)
    except (ProcessLookupError, PermissionError):
        pass


REGISTRY = ProcessRegistry()

#: the signals that stop a run as Ctrl-C does: a CI system cancelling a job or `timeout`
#: (SIGTERM), a closed terminal (SIGHUP). Every step runs in a session of its own, so none of
#: them reaches the steps: wsbuild must pass it on, or they outlive it
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
#: a stop signal repeated this soon is the same request (`timeout` signals wsbuild, then its
#: whole process group); a later one cuts the grace period short, as a second Ctrl-C does
_SAME_REQUEST_SECONDS = 1.0


class Stopped(KeyboardInterrupt):
    """A stop signal (SIGTERM, SIGHUP) in the main thread: handled as Ctrl-C is, wherever the
    run is (waiting for the lock, running jobs), and exits 128 + the signal's number."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


_stopped_by: list[tuple[int, float]] = []


@contextmanager
def stop_signals_interrupt(registry: ProcessRegistry = REGISTRY) -> Iterator[None]:
    """While inside, SIGTERM and SIGHUP raise `Stopped` in the main thread, so the run stops
    every process it started (the same sweep, the same bounds as Ctrl-C) and releases the
    workspace lock only after they are gone. A later stop signal only hurries the sweep. Does
    nothing outside the main thread (Python delivers signals there only)."""
    _stopped_by.clear()  # a run of its own (cli.main called again in one process)
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, _frame: object) -> None:
        if not _stopped_by:
            _stopped_by.append((signum, time.monotonic()))
            raise Stopped(signum)
        if time.monotonic() - _stopped_by[0][1] >= _SAME_REQUEST_SECONDS:
            registry.hurry()

    previous = {sig: signal.signal(sig, handler) for sig in STOP_SIGNALS}
    try:
        yield
    finally:
        for sig, action in previous.items():
            signal.signal(sig, action)


def interrupted_exit_code() -> int:
    """The exit code of an interrupted run: 128 + the signal that stopped it (130 for Ctrl-C,
    143 for SIGTERM, 129 for SIGHUP), as a shell reports a command its signal killed."""
    signum = _stopped_by[0][0] if _stopped_by else signal.SIGINT
    return 128 + int(signum)


@dataclass(frozen=True, slots=True)
class Completed:
    """A command that ran to its end: its exit code and the last lines it printed."""

    returncode: int
    tail: tuple[str, ...]  # last lines of combined output
    stderr: tuple[str, ...]  # every stderr line
    #: what was still running in the command's session after it exited, and was stopped
    #: (`run_command(sweep=True)`): "name (pid)"
    stopped: tuple[str, ...] = ()


def session_members(sid: int) -> dict[int, str]:
    """The living processes of session `sid` (pid → name), from /proc; a zombie has ended."""
    found: dict[int, str] = {}
    for pid, name, fields in _processes():
        # after the name: state, ppid, pgrp, session
        if len(fields) > 3 and int(fields[3]) == sid and fields[0] not in (b"Z", b"X"):
            found[pid] = name
    return found


def _processes() -> Iterator[tuple[int, str, list[bytes]]]:
    """Every process in /proc (none where there is no /proc): its pid, its name, and the
    fields of its stat after the name (state, ppid, pgrp, session, ...)."""
    try:
        entries = os.listdir("/proc")
    except OSError:
        return
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as handle:
                stat = handle.read()
        except OSError:  # gone meanwhile
            continue
        # "pid (comm) state ppid ...": comm may hold spaces and parentheses
        name = stat[stat.find(b"(") + 1:stat.rfind(b")")].decode(errors="replace")
        yield int(entry), name, stat.rpartition(b")")[2].split()


def sweep_session(sid: int) -> tuple[str, ...]:
    """Stop what is left of session `sid` (a test's nodes, a daemon it started), as a
    cancelled run stops its steps: SIGTERM, SIGKILL after `GRACE_SECONDS`, at most
    `_KILL_SECONDS` more. Returns what was found running, "name (pid)"."""
    left = session_members(sid)
    if not left:
        return ()
    for pid in left:
        _signal_process(pid, signal.SIGTERM)
        _signal_process(pid, signal.SIGCONT)
    deadline = time.monotonic() + GRACE_SECONDS
    while session_members(sid) and time.monotonic() < deadline:
        time.sleep(_POLL_SECONDS)
    deadline = time.monotonic() + _KILL_SECONDS
    while (alive := session_members(sid)) and time.monotonic() < deadline:
        for pid in alive:
            _signal_process(pid, signal.SIGKILL)
        time.sleep(_POLL_SECONDS / 5)
    return tuple(f"{name} ({pid})" for pid, name in sorted(left.items()))


def env_delta(env: Mapping[str, str], base: Mapping[str, str]) -> dict[str, str]:
    """The variables of `env` that differ from `base` (for reproduce-by-hand commands)."""
    return {k: v for k, v in sorted(env.items()) if base.get(k) != v}


def format_command(command: Sequence[str], cwd: Path, delta: Mapping[str, str]) -> str:
    """A shell line that reproduces a command by hand."""
    import shlex  # lazy: off a run that starts no command

    exports = " ".join(f"{k}={shlex.quote(v)}" for k, v in delta.items())
    cmd = " ".join(shlex.quote(c) for c in command)
    return f"cd {shlex.quote(str(cwd))} && {exports + ' ' if exports else ''}{cmd}"


def run_command(
    command: Sequence[str],
    *,
    cwd: Path,
    env: Mapping[str, str],
    log_dir: Path | None = None,
    on_line: Callable[[str, bool], None] | None = None,
    pass_fds: Sequence[int] = (),
    registry: ProcessRegistry = REGISTRY,
    tail_lines: int = 40,
    sweep: bool = False,
) -> Completed:
    """Run `command`, appending to `log_dir`'s stdout.log / stderr.log / stdout_stderr.log.
    `sweep` (a test step): once the command exits, whatever is left in its session is
    stopped (`sweep_session`), also what still holds its output open. Over 80 lines because
    one command's life reads best top to bottom: start, stream its output, sweep, reap."""
    import selectors
    import subprocess  # lazy (both): off a run that starts no command

    if registry.cancelled.is_set():
        return Completed(returncode=-int(signal.SIGTERM), tail=(), stderr=())
    logs: dict[str, object] = {}
    if log_dir is not None:
        log_dir.mkdir(parents=True, exist_ok=True)
        for name in ("stdout", "stderr", "stdout_stderr"):
            logs[name] = open(log_dir / f"{name}.log", "ab")  # noqa: SIM115
    tail: deque[str] = deque(maxlen=tail_lines)
    stderr_lines: list[str] = []
    try:
        proc = subprocess.Popen(
            list(command),
            cwd=cwd,
            env=dict(env),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            start_new_session=True,
            pass_fds=tuple(pass_fds),
        )
    except OSError as exc:
        for handle in logs.values():
            handle.close()  # type: ignore[attr-defined]
        message = f"cannot run {command[0]}: {exc.strerror}"
        return Completed(returncode=127, tail=(message,), stderr=(message,))
    registry.add(proc)
    try:
        selector = selectors.DefaultSelector()
        assert proc.stdout is not None and proc.stderr is not None
        selector.register(proc.stdout, selectors.EVENT_READ, False)
        selector.register(proc.stderr, selectors.EVENT_READ, True)
        partial = {False: b"", True: b""}
        open_streams = 2
        stopped: tuple[str, ...] = ()
        while open_streams:
            ready = selector.select(timeout=_POLL_SECONDS * 10 if sweep else None)
            if sweep and not ready and not stopped and proc.poll() is not None:
                # exited, its output still held open by what it left running
                stopped = sweep_session(proc.pid) or ("?",)
            for key, _ in ready:
                is_err: bool = key.data
                chunk = os.read(key.fd, 65536)
                if not chunk:
                    selector.unregister(key.fileobj)
                    open_streams -= 1
                    lines = [partial[is_err]] if partial[is_err] else []
                    partial[is_err] = b""
                else:
                    data = partial[is_err] + chunk
                    *lines, partial[is_err] = data.split(b"\n")
                    lines = [line + b"\n" for line in lines]
                for raw in lines:
                    raw = redact_bytes(raw)
                    for name in ("stderr" if is_err else "stdout", "stdout_stderr"):
                        if name in logs:
                            logs[name].write(raw)  # type: ignore[attr-defined]
                    text = raw.decode(errors="replace").rstrip("\n")
                    tail.append(text)
                    if is_err:
                        stderr_lines.append(text)
                    if on_line is not None:
                        on_line(text, is_err)
        selector.close()
        returncode = proc.wait()
        if sweep:
            stopped = tuple(p for p in (*stopped, *sweep_session(proc.pid)) if p != "?")
    finally:
        if proc.poll() is None:
            _signal_group(proc.pid, signal.SIGKILL)
            proc.wait()
        registry.remove(proc)
        for handle in logs.values():
            handle.close()  # type: ignore[attr-defined]
    return Completed(returncode=returncode, tail=tuple(tail), stderr=tuple(stderr_lines),
                     stopped=stopped)
