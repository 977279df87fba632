"""A real nginx with WebDAV PUT on a free loopback port: the HTTP cache server of the cache tests.

Use it as a pytest plugin (`pytest_plugins = ["nginx_server"]`): the `nginx` fixture starts
Debian's nginx (scripts/setup.sh installs it) with its configuration, storage root, logs and
pid file in a temporary directory, and stops it afterwards.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

CONFIG = """\
{user}
worker_processes 1;
daemon off;
pid {home}/nginx.pid;
error_log {home}/error.log warn;
events {{ worker_connections 128; }}
http {{
    log_format cache '$request_method $uri $status auth=$http_authorization';
    access_log {home}/access.log cache;
    client_body_temp_path {home}/body;
    proxy_temp_path {home}/proxy;
    fastcgi_temp_path {home}/fastcgi;
    uwsgi_temp_path {home}/uwsgi;
    scgi_temp_path {home}/scgi;
    client_max_body_size 0;
    server {{
        listen 127.0.0.1:{port};
        root {home}/root;
        location / {{
            {dav}
            create_full_put_path on;
            dav_access user:rw group:r all:r;
        }}
    }}
}}
"""


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class NginxServer:
    """One nginx process; `url` is its base URL, `root` the directory it serves and stores."""

    def __init__(self, home: Path, *, allow_put: bool = True) -> None:
        self.home = home
        self.root = home / "root"
        self.allow_put = allow_put
        self.port = 0
        self.process: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/"

    def start(self) -> None:
        nginx = shutil.which("nginx") or "/usr/sbin/nginx"
        self.root.mkdir(parents=True, exist_ok=True)
        for attempt in range(5):
            self.port = self.port if self.port and attempt == 0 else free_port()
            config = self.home / "nginx.conf"
            config.write_text(CONFIG.format(
                home=self.home, port=self.port,
                user="user root;" if os.geteuid() == 0 else "",
                dav="dav_methods PUT;" if self.allow_put else "dav_methods off;",
            ))
            self.process = subprocess.Popen(
                [nginx, "-p", str(self.home), "-c", str(config), "-e", str(self.home / "error.log")],
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
            )
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline and self.process.poll() is None:
                try:
                    socket.create_connection(("127.0.0.1", self.port), timeout=0.2).close()
                    return
                except OSError:
                    time.sleep(0.02)
            self.stop()
        log = (self.home / "error.log").read_text() if (self.home / "error.log").exists() else ""
        raise RuntimeError(f"nginx did not start: {log}")

    def stop(self) -> None:
        if self.process is None:
            return
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)  # fast shutdown
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        if self.process.stderr is not None:
            self.process.stderr.close()
        self.process = None

    def requests(self, at_least: int = 0, method: str = "") -> list[str]:
        """The access log: one 'METHOD /uri STATUS auth=…' line per request (only `method`'s,
        when given). nginx logs a request after answering it: with `at_least`, wait (up to
        10 s) for that many lines."""
        path = self.home / "access.log"
        deadline = time.monotonic() + 10
        while True:
            lines = path.read_text().splitlines() if path.exists() else []
            lines = [line for line in lines if line.startswith(f"{method} ")] if method else lines
            if len(lines) >= at_least or time.monotonic() > deadline:
                return lines
            time.sleep(0.02)

    def stored(self, kind: str) -> list[Path]:
        """The files under /cas or /ac."""
        directory = self.root / kind
        return sorted(directory.iterdir()) if directory.exists() else []


@pytest.fixture
def nginx(tmp_path_factory: pytest.TempPathFactory) -> Iterator[NginxServer]:
    """A started nginx with WebDAV PUT; stopped when the test ends."""
    server = NginxServer(tmp_path_factory.mktemp("nginx"))
    server.start()
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture
def nginx_no_put(tmp_path_factory: pytest.TempPathFactory) -> Iterator[NginxServer]:
    """An nginx that serves files but refuses PUT (405), like a read-only cache."""
    server = NginxServer(tmp_path_factory.mktemp("nginx"), allow_put=False)
    server.start()
    try:
        yield server
    finally:
        server.stop()
