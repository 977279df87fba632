"""`wsbuild build` and other processes: Ctrl-C, and two builds of one workspace at once."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from conftest import sigint_at_default
from test_build_helpers import build, clean_env, output, snapshot, write_cmake, wsbuild

GATED_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project({name} NONE)
# while the gate file exists the build hangs in a command that names the marker
add_custom_target(wait_at_gate ALL COMMAND sh ${{CMAKE_CURRENT_SOURCE_DIR}}/gate.sh {marker})
install(FILES data.txt DESTINATION share/${{PROJECT_NAME}})
"""


def _pids(pattern: str) -> list[int]:
    found = subprocess.run(["pgrep", "-f", pattern], capture_output=True, text=True)
    return [int(p) for p in found.stdout.split()]


def _wait_for(condition: Callable[[], bool], seconds: float, what: str,
              running: subprocess.Popen[bytes], log: Path) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        if running.poll() is not None:
            raise AssertionError(f"wsbuild exited ({running.returncode}) before {what}:\n"
                                 + log.read_text())
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)


@pytest.fixture
def marker() -> Iterator[str]:
    """A unique word on the command line of every process a test's build starts; `sleep`
    gets a unique duration derived from it (see `_duration`)."""
    word = f"wsbuild_test_{uuid.uuid4().hex}"
    yield word
    # only ever our own processes: the marker and the duration are unique
    for pid in _pids(word) + _pids(f"sleep {_duration(word)}"):
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def _duration(marker: str) -> str:
    """`sleep 30`, with a fractional part nobody else uses, so pgrep finds exactly ours."""
    return f"30.{int(marker[-8:], 16)}"


def _start_build(ws: Path, *args: str, stdout: Path) -> subprocess.Popen[bytes]:
    """`wsbuild build` in its own session, like a shell's foreground job."""
    with open(stdout, "wb") as handle:
        return subprocess.Popen([sys.executable, "-m", "wsbuild", "build", *args], cwd=ws,
                                env=clean_env(), stdout=handle, stderr=subprocess.STDOUT,
                                start_new_session=True, preexec_fn=sigint_at_default)


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def test_ctrl_c_stops_the_build_and_every_process_it_started(tmp_path: Path, marker: str) -> None:
    ws = tmp_path / "ws"
    gate = tmp_path / "gate"
    duration = _duration(marker)
    body = f"if [ -e '{gate}' ]; then exec sleep {duration}; fi\n"
    write_cmake(ws / "src", "slow", GATED_CMAKE.format(name="slow", marker=marker),
                files={"data.txt": "slow v1\n", "gate.sh": body})
    build(ws)
    before = snapshot(ws / "install" / "slow")
    (ws / "src" / "slow" / "data.txt").write_text("slow v2\n")
    gate.touch()

    log = tmp_path / "build.out"
    proc = _start_build(ws, stdout=log)
    try:
        _wait_for(lambda: bool(_pids(f"sleep {duration}")), 60, "the build to reach sleep",
                  proc, log)
        pressed = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)  # what the terminal does on Ctrl-C
        returncode = proc.wait(timeout=15)
        seconds = time.monotonic() - pressed
    finally:
        _stop(proc)
    text = log.read_text()
    assert returncode == 130, text
    assert seconds < 6, f"took {seconds:.1f}s to stop"
    assert "Summary:" in text, text
    assert "aborted: slow" in text, text
    time.sleep(0.2)
    assert _pids(marker) == [] and _pids(f"sleep {duration}") == []
    # the interrupted package keeps its previous install; the next build finishes the job
    assert snapshot(ws / "install" / "slow") == before
    gate.unlink()
    build(ws)
    assert (ws / "install" / "slow" / "share" / "slow" / "data.txt").read_text() == "slow v2\n"


def test_second_build_waits_for_the_first_or_fails_with_no_wait(tmp_path: Path,
                                                                marker: str) -> None:
    ws = tmp_path / "ws"
    gate = tmp_path / "gate"
    body = f"while [ -e '{gate}' ]; do sleep 0.05; done\n"
    write_cmake(ws / "src", "locked", GATED_CMAKE.format(name="locked", marker=marker),
                files={"data.txt": "locked v1\n", "gate.sh": body})
    gate.touch()
    first_log, second_log = tmp_path / "first.out", tmp_path / "second.out"
    first = _start_build(ws, stdout=first_log)
    second: subprocess.Popen[bytes] | None = None
    try:
        _wait_for(lambda: bool(_pids(marker)), 60, "the first build to start building",
                  first, first_log)

        refused = wsbuild("build", "--no-wait", cwd=ws, timeout=30)
        assert refused.returncode == 2, output(refused)
        assert f"another wsbuild (pid {first.pid})" in refused.stderr
        assert "Starting" not in refused.stdout

        second = _start_build(ws, stdout=second_log)
        _wait_for(lambda: "waiting" in second_log.read_text(), 30, "the second build to wait",
                  second, second_log)
        assert second.poll() is None
        assert first.poll() is None

        # Ctrl-C on a waiting build ends it at once and leaves the running one alone
        third_log = tmp_path / "third.out"
        third = _start_build(ws, stdout=third_log)
        try:
            _wait_for(lambda: "waiting" in third_log.read_text(), 30, "the third build to wait",
                      third, third_log)
            os.killpg(third.pid, signal.SIGINT)
            assert third.wait(timeout=10) == 130, third_log.read_text()
        finally:
            _stop(third)
        assert "Traceback" not in third_log.read_text()
        assert first.poll() is None

        gate.unlink()
        assert first.wait(timeout=60) == 0, first_log.read_text()
        assert second.wait(timeout=60) == 0, second_log.read_text()
    finally:
        _stop(first)
        if second is not None:
            _stop(second)
    assert f"another wsbuild (pid {first.pid}) is building this workspace" in \
        second_log.read_text()
    data = ws / "install" / "locked" / "share" / "locked" / "data.txt"
    assert data.read_text() == "locked v1\n"
    assert not (ws / "install" / ".wsbuild-stage").exists()
    again = wsbuild("build", cwd=ws)
    assert again.returncode == 0, output(again)


SLOW_INSTALL_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(slowinst NONE)
install(FILES data.txt DESTINATION share/${PROJECT_NAME})
install(CODE "execute_process(COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/gate.sh {marker})")
install(FILES more.txt DESTINATION share/${PROJECT_NAME})
"""


def _slow_install_ws(root: Path, gate: Path, marker: str) -> Path:
    """A package whose install step hangs while `gate` exists, in a `sleep` that ignores
    SIGTERM (like a tool slow to stop), after installing half of its files."""
    ws = root / "ws"
    body = (f"if [ -e '{gate}' ]; then trap '' TERM; sleep {_duration(marker)}; fi\n")
    write_cmake(ws / "src", "slowinst", SLOW_INSTALL_CMAKE.replace("{marker}", marker),
                files={"data.txt": "v1\n", "more.txt": "v1\n", "gate.sh": body})
    return ws


def _interrupt_install(tmp_path: Path, marker: str, presses: int) -> None:
    ws = _slow_install_ws(tmp_path, tmp_path / "gate", marker)
    build(ws)
    before = snapshot(ws / "install" / "slowinst")
    (ws / "src" / "slowinst" / "data.txt").write_text("v2\n")
    (tmp_path / "gate").touch()
    log = tmp_path / "build.out"
    proc = _start_build(ws, stdout=log)
    try:
        _wait_for(lambda: bool(_pids(f"sleep {_duration(marker)}")), 60,
                  "the install step to hang", proc, log)
        pressed = time.monotonic()
        for press in range(presses):
            if press:
                time.sleep(1)  # impatient: Ctrl-C again while wsbuild is still stopping
            os.killpg(proc.pid, signal.SIGINT)
        returncode = proc.wait(timeout=20)
        seconds = time.monotonic() - pressed
    finally:
        _stop(proc)
    text = log.read_text()
    assert returncode == 130, text
    assert seconds < 8, f"took {seconds:.1f}s to stop"
    time.sleep(0.2)
    assert _pids(f"sleep {_duration(marker)}") == [], "a process of the build survived"
    assert snapshot(ws / "install" / "slowinst") == before, "the previous install changed"
    (tmp_path / "gate").unlink()
    build(ws)
    assert (ws / "install" / "slowinst" / "share" / "slowinst" / "data.txt").read_text() == "v2\n"


def test_ctrl_c_during_install_keeps_the_previous_install(tmp_path: Path, marker: str) -> None:
    _interrupt_install(tmp_path, marker, presses=1)


def test_ctrl_c_pressed_twice_still_stops_everything_and_keeps_the_install(
        tmp_path: Path, marker: str) -> None:
    _interrupt_install(tmp_path, marker, presses=2)


# ------------------------------------------ Ctrl-C reaches every descendant (issue 32)

STEP_CMAKE = """\
cmake_minimum_required(VERSION 3.14)
project(gen NONE)
# a code generator: Ninja runs it in a process group of its own
add_custom_command(OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/generated.txt
  COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/step.sh ${CMAKE_CURRENT_BINARY_DIR}/generated.txt
  DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/step.sh)
add_custom_target(generate ALL DEPENDS ${CMAKE_CURRENT_BINARY_DIR}/generated.txt)
"""


def _state(pid: int) -> str | None:
    """The /proc state letter of `pid` (None: gone)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat.rpartition(")")[2].split()[0]


def _alive(pid: int) -> bool:
    return _state(pid) not in (None, "Z", "X")


def _ninja_above(pid: int) -> int:
    """The `ninja` process that runs build step `pid`."""
    current = pid
    while current > 1:
        stat = Path(f"/proc/{current}/stat").read_text()
        if Path(f"/proc/{current}/comm").read_text().strip() == "ninja":
            return current
        current = int(stat.rpartition(")")[2].split()[1])
    raise AssertionError(f"no ninja above build step {pid}")


def _generator_ws(tmp_path: Path, marker: str, *, ignore_sigterm: bool) -> tuple[Path, Path]:
    """A package whose Ninja build step writes its pid to a file and sleeps (ignoring SIGTERM
    if asked): (workspace, pid file)."""
    ws = tmp_path / "ws"
    pid_file = tmp_path / "step.pid"
    trap = "trap '' TERM\n" if ignore_sigterm else ""
    body = f"{trap}echo $$ > '{pid_file}'\nexec sleep {_duration(marker)}\n"
    write_cmake(ws / "src", "gen", STEP_CMAKE, files={"step.sh": body})
    return ws, pid_file


def _step_started(tmp_path: Path, ws: Path, pid_file: Path) -> tuple[subprocess.Popen[bytes], int,
                                                                        Path]:
    log = tmp_path / "build.out"
    proc = _start_build(ws, stdout=log)
    _wait_for(lambda: pid_file.is_file() and pid_file.read_text().strip().isdigit(), 60,
              "the build step to start", proc, log)
    step = int(pid_file.read_text())
    _wait_for(lambda: (Path(f"/proc/{step}/cmdline").read_bytes().startswith(b"sleep")
                       if _alive(step) else False), 10, "the build step to sleep", proc, log)
    return proc, step, log


def _kill(*pids: int) -> None:
    for pid in pids:
        for sig in (signal.SIGCONT, signal.SIGKILL):
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass


@pytest.mark.parametrize("presses", [1, 2])
def test_ctrl_c_ends_a_ninja_build_step_that_ignores_sigterm(tmp_path: Path, marker: str,
                                                             presses: int) -> None:
    """Ninja gives each step its own process group and passes SIGTERM on to it; a step that
    ignores it is killed when the grace period ends, or at once on a second Ctrl-C."""
    from wsbuild.engine.process import GRACE_SECONDS

    ws, pid_file = _generator_ws(tmp_path, marker, ignore_sigterm=True)
    proc, step, log = _step_started(tmp_path, ws, pid_file)
    ninja = _ninja_above(step)
    assert os.getpgid(step) != os.getpgid(ninja)  # the case this test is about
    try:
        pressed = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        if presses == 2:
            # wsbuild is stopping: Ninja got its SIGTERM and went; the step is still there
            _wait_for(lambda: not _alive(ninja), GRACE_SECONDS, "ninja to stop", proc, log)
            assert _alive(step)
            pressed = time.monotonic()
            os.killpg(proc.pid, signal.SIGINT)
        returncode = proc.wait(timeout=30)
        seconds = time.monotonic() - pressed
        step_alive_at_exit = _alive(step)
    finally:
        _kill(step, ninja)
        _stop(proc)
    text = log.read_text()
    assert returncode == 130, text
    assert not step_alive_at_exit, "the build step that ignores SIGTERM survived Ctrl-C"
    assert "aborted: gen" in text, text
    if presses == 1:
        assert GRACE_SECONDS <= seconds < GRACE_SECONDS + 5, f"stopped {seconds:.2f}s after Ctrl-C"
    else:
        assert seconds < GRACE_SECONDS / 2, f"stopped {seconds:.2f}s after the second Ctrl-C"


def test_ctrl_c_ends_the_build_steps_of_a_stopped_ninja(tmp_path: Path, marker: str) -> None:
    """A stopped (or swapped-out) Ninja cannot pass the signal on: wsbuild reaches its steps
    itself, and ends Ninja too."""
    from wsbuild.engine.process import GRACE_SECONDS

    ws, pid_file = _generator_ws(tmp_path, marker, ignore_sigterm=False)
    proc, step, log = _step_started(tmp_path, ws, pid_file)
    ninja = _ninja_above(step)
    try:
        os.kill(ninja, signal.SIGSTOP)
        _wait_for(lambda: _state(ninja) == "T", 10, "ninja to stop", proc, log)
        pressed = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        returncode = proc.wait(timeout=30)
        seconds = time.monotonic() - pressed
        alive_at_exit = [pid for pid in (step, ninja) if _alive(pid)]
    finally:
        _kill(step, ninja)
        _stop(proc)
    text = log.read_text()
    assert returncode == 130, text
    assert alive_at_exit == [], f"survived Ctrl-C: {alive_at_exit} (step {step}, ninja {ninja})"
    # nothing here ignores SIGTERM: no need to wait out the grace period
    assert seconds < GRACE_SECONDS, f"stopped {seconds:.2f}s after Ctrl-C"


def test_the_ctrl_c_tests_pass_when_the_suite_starts_with_sigint_ignored(tmp_path: Path) -> None:
    """A suite started as a background job of a script inherits SIGINT ignored (and so would
    every wsbuild it starts): the Ctrl-C tests start wsbuild with SIGINT at its default."""
    ignoring = ["bash", "-c", 'trap "" INT; exec "$@"', "bash"]
    env = {k: v for k, v in clean_env().items() if k != "PYTEST_ADDOPTS"}
    ignored = "import signal; print(signal.getsignal(signal.SIGINT) == signal.SIG_IGN)"
    probe = subprocess.run([*ignoring, sys.executable, "-c", ignored],
                           env=env, capture_output=True, text=True, timeout=60)
    assert probe.stdout.strip() == "True"  # the situation this test is about
    test = ("tests/test_build_concurrency.py::"
            "test_ctrl_c_stops_the_build_and_every_process_it_started")
    suite = subprocess.run([*ignoring, sys.executable, "-m", "pytest", "-q", "-p",
                            "no:cacheprovider", f"--basetemp={tmp_path / 'inner'}", test],
                           cwd=Path(__file__).resolve().parent.parent, env=env,
                           capture_output=True, text=True, timeout=300)
    assert suite.returncode == 0, suite.stdout + suite.stderr
    assert "1 passed" in suite.stdout, suite.stdout


# ------------------------------------ SIGTERM and SIGHUP stop a build as Ctrl-C does (issue 37)

TRACED_STEP = """\
echo "start $$" >> '@TRACE@'
# a build step of an earlier build still alive now is two builds in one build directory
for pid in $(cat '@PIDS@' 2>/dev/null); do
  if [ -e /proc/$pid ] && ! grep -q '^State:[[:space:]]*Z' /proc/$pid/status 2>/dev/null; then
    echo "overlap $pid" >> '@TRACE@'
  fi
done
echo $$ >> '@PIDS@'
if [ -e '@GATE@' ]; then trap '' TERM; sleep @DURATION@; fi
echo "end $$" >> '@TRACE@'
touch "$1"
"""


@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
def test_sigterm_and_sighup_stop_every_build_step_before_the_next_build_starts(
        tmp_path: Path, marker: str, stop: signal.Signals) -> None:
    """A CI system cancelling a job (`timeout -s TERM`, SIGTERM to wsbuild alone) or a closed
    terminal (SIGHUP) stops the build's steps too, even one that ignores SIGTERM; a build
    started at once waits for the lock, which is released only once they are gone, so the two
    never overlap. The exit code is the shell's for that signal."""
    ws = tmp_path / "ws"
    trace, pids, gate = tmp_path / "trace", tmp_path / "pids", tmp_path / "gate"
    body = (TRACED_STEP.replace("@TRACE@", str(trace)).replace("@PIDS@", str(pids))
            .replace("@GATE@", str(gate)).replace("@DURATION@", _duration(marker)))
    write_cmake(ws / "src", "gen", STEP_CMAKE, files={"step.sh": body})
    gate.touch()
    first_log, second_log = tmp_path / "first.out", tmp_path / "second.out"
    first = _start_build(ws, stdout=first_log)
    second: subprocess.Popen[bytes] | None = None
    try:
        _wait_for(lambda: bool(_pids(f"sleep {_duration(marker)}")), 60,
                  "the build step to start", first, first_log)
        step = int(pids.read_text().split()[0])
        os.kill(first.pid, stop)  # wsbuild alone, not its process group
        gate.unlink()
        second = _start_build(ws, stdout=second_log)
        returncode = first.wait(timeout=30)
        step_alive_at_exit = _alive(step)
        assert second.wait(timeout=120) == 0, second_log.read_text()
    finally:
        _stop(first)
        if second is not None:
            _stop(second)
    assert returncode == 128 + stop, first_log.read_text()
    assert not step_alive_at_exit, f"the build step outlived wsbuild after {stop.name}"
    lines = trace.read_text().splitlines()
    assert [line.split()[0] for line in lines] == ["start", "start", "end"], lines
    assert "Traceback" not in first_log.read_text()


# ------------------------------- a stopped wsbuild holds the workspace until it is gone (issue 43)

#: every step of the next build (its configure and its build step) notes, as it starts,
#: whether a step of an earlier build or the stopped wsbuild is still alive
CHECK_ALIVE = """\
echo "start $$" >> '@TRACE@'
for pid in $(cat '@PIDS@' 2>/dev/null) $(cat '@OLD@' 2>/dev/null); do
  if [ -e /proc/$pid ] && ! grep -q '^State:[[:space:]]*Z' /proc/$pid/status 2>/dev/null; then
    echo "overlap $pid" >> '@TRACE@'
  fi
done
"""

CHECKED_STEP_CMAKE = STEP_CMAKE.replace(
    "project(gen NONE)",
    "project(gen NONE)\nexecute_process(COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/check.sh)")


def _fill(pipe_write: int, pipe_read: int) -> None:
    """Fill a pipe whose reader has stopped reading, as a busy CI runner's log collector does:
    the next write of the process on the other end blocks."""
    import fcntl
    import termios

    fcntl.fcntl(pipe_write, 1031, 4096)  # F_SETPIPE_SZ: one page
    capacity = fcntl.fcntl(pipe_write, 1032)  # F_GETPIPE_SZ
    waiting = bytearray(4)
    fcntl.ioctl(pipe_read, termios.FIONREAD, waiting)
    os.write(pipe_write, b"x" * (capacity - int.from_bytes(waiting, sys.byteorder)))


def _blocked_in_a_full_pipe_holding_the_lock(pid: int, lock: Path) -> bool:
    """Whether wsbuild `pid` waits to write into a full pipe while it holds the workspace's
    lock (/proc/<pid>/wchan, /proc/locks): only its reader can let it go on."""
    try:
        if "pipe_write" not in Path(f"/proc/{pid}/wchan").read_text():
            return False
        inode = lock.stat().st_ino
    except OSError:
        return False
    return any(fields[1] == "FLOCK" and fields[4] == str(pid)
               and fields[5].endswith(f":{inode}")
               for fields in (line.split() for line in Path("/proc/locks").read_text().splitlines())
               if len(fields) > 5)


def test_a_stopped_build_holds_the_workspace_until_it_and_every_step_are_gone(
        tmp_path: Path, marker: str) -> None:
    """A CI runner sends SIGTERM to a build, then starts the next one in the same workspace at
    once; its log collector reads late (the stopped wsbuild's last line waits in a full pipe,
    until the next build has started a step or the stopped one waits for it with the lock).
    The next build never starts a step, configure included, while a step of the stopped build
    or the stopped wsbuild itself is alive: it waits for the lock, which the stopped wsbuild
    holds until it has exited. (The suite runs this on a loaded machine: two workers.)"""
    ws = tmp_path / "ws"
    trace, pids, old, gate = (tmp_path / name for name in ("trace", "pids", "old", "gate"))
    check = (CHECK_ALIVE.replace("@TRACE@", str(trace)).replace("@PIDS@", str(pids))
             .replace("@OLD@", str(old)))
    body = (check + f"echo $$ >> '{pids}'\n"
            f"if [ -e '{gate}' ]; then trap '' TERM; sleep {_duration(marker)}; fi\n"
            'touch "$1"\n')
    write_cmake(ws / "src", "gen", CHECKED_STEP_CMAKE, files={"step.sh": body, "check.sh": check})
    gate.touch()
    first_log, second_log = tmp_path / "first.out", tmp_path / "second.out"
    err_read, err_write = os.pipe()
    with open(first_log, "wb") as handle:
        first = subprocess.Popen([sys.executable, "-m", "wsbuild", "build"], cwd=ws,
                                 env=clean_env(), stdout=handle, stderr=err_write,
                                 start_new_session=True, preexec_fn=sigint_at_default)
    second: subprocess.Popen[bytes] | None = None
    try:
        _wait_for(lambda: bool(_pids(f"sleep {_duration(marker)}")), 60,
                  "the build step to start", first, first_log)
        steps_of_first = len(trace.read_text().splitlines())
        old.write_text(f"{first.pid}\n")
        _fill(err_write, err_read)
        os.kill(first.pid, signal.SIGTERM)
        gate.unlink()
        # a new option: the next build configures again, so its first step is the configure
        second = _start_build(ws, "--cmake-args", "-DROUND=2", stdout=second_log)
        lock = ws / "build" / ".wsbuild.build.lock"
        _wait_for(lambda: len(trace.read_text().splitlines()) > steps_of_first
                  or _blocked_in_a_full_pipe_holding_the_lock(first.pid, lock), 60,
                  "the next build to start a step, or the stopped one to wait for its reader",
                  second, second_log)
        # the log collector catches up
        os.close(err_write)
        err_write = -1
        while os.read(err_read, 65536):
            pass
        returncode = first.wait(timeout=30)
        assert second.wait(timeout=120) == 0, second_log.read_text()
    finally:
        if err_write >= 0:
            os.close(err_write)
        os.close(err_read)
        _stop(first)
        if second is not None:
            _stop(second)
    assert returncode == 128 + signal.SIGTERM, first_log.read_text()
    lines = trace.read_text().splitlines()
    assert not [line for line in lines if line.startswith("overlap")], \
        f"the next build started a step while the stopped one lived (pid {first.pid}): {lines}"
    assert [line.split()[0] for line in lines].count("start") == steps_of_first + 2, lines
    assert f"another wsbuild (pid {first.pid})" in second_log.read_text()
