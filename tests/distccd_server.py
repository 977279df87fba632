"""Real distcc daemons on free loopback ports: the build hosts of the distribution tests.

Import the `distccd` fixture from here: it starts
Debian's `distccd` (scripts/setup.sh installs it) with `--allow 127.0.0.1 --listen 127.0.0.1`,
its log in a temporary directory, and stops it afterwards. distcc ≥ 3.3 compiles only with
compilers whitelisted in /usr/lib/distcc (`update-distcc-symlinks`); when the system has no
such whitelist for the test's compilers, the daemon gets one of its own in a temporary
directory (`DISTCC_CMDLIST`).
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

SYSTEM_WHITELIST = Path("/usr/lib/distcc")
COMPILERS = ("c++", "g++", "cc", "gcc")


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class Distccd:
    """One distccd; `host` is its entry for DISTCC_HOSTS without a limit."""

    def __init__(self, home: Path, *, jobs: int = 4) -> None:
        self.home = home
        self.port = free_port()
        self.log = home / "distccd.log"
        home.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ)
        whitelist = _own_whitelist(home)
        if whitelist is not None:
            env.update(DISTCC_CMDLIST=str(whitelist), DISTCC_CMDLIST_NUMWORDS="1")
        with open(self.log, "wb") as log:
            # --log-stderr: the daemon drops root to an unprivileged user, who could not open
            # a log file of ours; its inherited stderr stays writable
            self.process = subprocess.Popen(
                ["distccd", "--daemon", "--no-detach", "--log-stderr", "--log-level=info",
                 "--allow", "127.0.0.1", "--listen", "127.0.0.1", "--port", str(self.port),
                 "--jobs", str(jobs)],
                stdin=subprocess.DEVNULL, stdout=log, stderr=log, env=env,
                start_new_session=True)
        self._wait_listening()

    @property
    def host(self) -> str:
        return f"127.0.0.1:{self.port}"

    def compiled(self, suffix: str = ".cpp") -> list[str]:
        """Sources the daemon compiled successfully (its job summaries), in order."""
        names = []
        for line in self.log.read_text(errors="replace").splitlines():
            if "COMPILE_OK" in line:
                source = line.rsplit(" ", 1)[-1]
                if source.endswith(suffix) and "probe" not in source:
                    names.append(Path(source).name)
        return names

    def stop(self) -> None:
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGTERM)
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()

    def _wait_listening(self) -> None:
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"distccd exited: {self.log.read_text(errors='replace')}")
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.5):
                    return
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise RuntimeError(f"distccd did not listen on port {self.port}")


def _own_whitelist(home: Path) -> Path | None:
    """A DISTCC_CMDLIST of the compilers on PATH when /usr/lib/distcc does not list them."""
    if all((SYSTEM_WHITELIST / name).exists() for name in COMPILERS if shutil.which(name)):
        return None
    found = [str(Path(p).resolve()) for p in map(shutil.which, COMPILERS) if p]
    found += [p for p in map(shutil.which, COMPILERS) if p]
    listed = home / "commands.allow"
    listed.write_text("\n".join(sorted(set(found))) + "\n")
    return listed


@pytest.fixture
def distccd(tmp_path: Path) -> Iterator[Callable[..., Distccd]]:
    """Start daemons with `distccd()` (each on its own free port); all stop after the test."""
    started: list[Distccd] = []

    def start(jobs: int = 4) -> Distccd:
        daemon = Distccd(tmp_path / f"distccd{len(started)}", jobs=jobs)
        started.append(daemon)
        return daemon

    yield start
    for daemon in started:
        daemon.stop()


class HangingAfterProbe:
    """A build host that answers wsbuild's probe and then hangs: a loopback TCP listener that
    passes its first connection through to a real distccd and accepts every later one without
    ever answering (a host that went into swap, a stuck NFS mount)."""

    def __init__(self, daemon: Distccd) -> None:
        import threading

        self.daemon = daemon
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.hung: list[socket.socket] = []
        self._threads: list[threading.Thread] = []
        self._accepting = threading.Thread(target=self._accept, daemon=True)
        self._accepting.start()

    @property
    def host(self) -> str:
        return f"127.0.0.1:{self.port}"

    def _accept(self) -> None:
        import threading

        first = True
        while True:
            try:
                client, _ = self.listener.accept()
            except OSError:  # closed by stop()
                return
            if first:
                first = False
                upstream = socket.create_connection(("127.0.0.1", self.daemon.port))
                for source, sink in ((client, upstream), (upstream, client)):
                    thread = threading.Thread(target=_pass, args=(source, sink), daemon=True)
                    thread.start()
                    self._threads.append(thread)
            else:
                self.hung.append(client)  # read nothing, answer nothing

    def stop(self) -> None:
        self.listener.close()
        for connection in self.hung:
            connection.close()


def _pass(source: socket.socket, sink: socket.socket) -> None:
    try:
        while data := source.recv(65536):
            sink.sendall(data)
        sink.shutdown(socket.SHUT_WR)
    except OSError:
        pass
