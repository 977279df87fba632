"""The HTTP cache tier: bazel-remote's plain HTTP layout, which nginx with WebDAV also serves.

GET/PUT/HEAD on <url>/cas/<sha256 of the blob> and <url>/ac/<sha256 of the cache key>.
Credentials come from WSBUILD_CACHE_TOKEN (a bearer token), the URL's user:password, or
~/.netrc, and never appear in a message. Connections are kept alive and shared by the
threads; every socket operation has a short timeout.
"""

from __future__ import annotations

import base64
import http.client
import netrc
import os
import socket
import threading
import urllib.parse
from collections.abc import Mapping
from pathlib import Path
from typing import BinaryIO

from wsbuild.cache.settings import DEFAULT_TIMEOUT, check_cache_url, redact
from wsbuild.redaction import remember

_MAX_RECORD = 1 << 20
_CHUNK = 1 << 16


class CacheUnavailable(Exception):
    """The server cannot be reached or answers with an error: the tier is off for this run."""


class CacheRejected(Exception):
    """The server refuses writes (e.g. 401, 403, 405): uploads are off for this run."""


class TruncatedDownload(Exception):
    """The body ended before its announced length."""


def _authorization(parsed: urllib.parse.SplitResult, environ: Mapping[str, str],
                   netrc_file: Path | None) -> str | None:
    token = environ.get("WSBUILD_CACHE_TOKEN", "").strip()
    if token:
        remember([token])
        return f"Bearer {token}"
    user, password = parsed.username, parsed.password
    if user is None:
        path = netrc_file or Path(environ.get("NETRC") or Path.home() / ".netrc")
        try:
            found = netrc.netrc(str(path)).authenticators(parsed.hostname or "")
        except (OSError, netrc.NetrcParseError):
            found = None
        if found is not None:
            user, _, password = found
    if user is None:
        return None
    raw = f"{urllib.parse.unquote(user)}:{urllib.parse.unquote(password or '')}".encode()
    basic = base64.b64encode(raw).decode()
    # what is sent, and the password in it, are never written (wsbuild/redaction.py)
    remember([urllib.parse.unquote(password or ""), password or "", basic])
    return "Basic " + basic


class HttpCache:
    def __init__(self, url: str, *, environ: Mapping[str, str] | None = None,
                 timeout: float = DEFAULT_TIMEOUT, netrc_file: Path | None = None) -> None:
        url = check_cache_url(url)
        parsed = urllib.parse.urlsplit(url)
        self.display = redact(url)
        self.https = parsed.scheme == "https"
        self.host = parsed.hostname or ""
        self.port = parsed.port
        self.base = parsed.path.rstrip("/")
        self.timeout = timeout
        self._auth = _authorization(parsed, os.environ if environ is None else environ,
                                    netrc_file)
        #: the connection of this thread's request in flight
        self._local = threading.local()
        #: kept-alive connections between requests, shared by all threads
        self._idle: list[http.client.HTTPConnection] = []
        self._idle_lock = threading.Lock()

    # -- connections ---------------------------------------------------------------------
    def _connection(self) -> tuple[http.client.HTTPConnection, bool]:
        """A connection for this thread's next request, and whether it was used before (and
        may have gone stale)."""
        with self._idle_lock:
            conn = self._idle.pop() if self._idle else None
        reused = conn is not None
        if conn is None:
            cls = http.client.HTTPSConnection if self.https else http.client.HTTPConnection
            conn = cls(self.host, self.port, timeout=self.timeout)
        self._local.conn = conn
        return conn, reused

    def _release_connection(self) -> None:
        conn = getattr(self._local, "conn", None)
        self._local.conn = None
        if conn is not None:
            with self._idle_lock:
                self._idle.append(conn)

    def _drop_connection(self) -> None:
        conn = getattr(self._local, "conn", None)
        self._local.conn = None
        if conn is not None:
            conn.close()

    def close(self) -> None:
        self._drop_connection()
        with self._idle_lock:
            idle, self._idle = self._idle, []
        for conn in idle:
            conn.close()

    def _send(self, method: str, path: str, body: bytes | BinaryIO | None,
              headers: dict[str, str]) -> http.client.HTTPResponse:
        if self._auth:
            headers = {**headers, "Authorization": self._auth}
        for attempt in (1, 2):
            conn, reused = self._connection()
            try:
                if hasattr(body, "seek"):
                    body.seek(0)  # type: ignore[union-attr]
                conn.request(method, self.base + path, body=body, headers=headers)
                return conn.getresponse()
            except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError,
                    http.client.CannotSendRequest) as error:
                self._drop_connection()
                if not reused or attempt == 2:
                    raise CacheUnavailable(f"{self.display}: {_describe(error)}") from None
                # a kept-alive connection the server closed meanwhile: one fresh try
            except (OSError, http.client.HTTPException) as error:
                self._drop_connection()
                raise CacheUnavailable(f"{self.display}: {_describe(error)}") from None
        raise AssertionError("unreachable")

    def _finish(self, response: http.client.HTTPResponse) -> None:
        """Read the rest of the response; its connection goes back to the idle ones."""
        try:
            response.read()
        except (OSError, http.client.HTTPException):
            self._drop_connection()
            return
        if response.will_close:
            self._drop_connection()
        else:
            self._release_connection()

    def _failed(self, method: str, path: str, response: http.client.HTTPResponse) -> Exception:
        self._finish(response)
        text = f"{self.display}: {method} {path} answered {response.status} {response.reason}"
        if method == "PUT" and 400 <= response.status < 500:
            return CacheRejected(text)
        return CacheUnavailable(text)

    # -- the layout ----------------------------------------------------------------------
    def get_action(self, address: str) -> bytes | None:
        path = f"/ac/{address}"
        response = self._send("GET", path, None, {"Accept": "application/json"})
        if response.status == 404:
            self._finish(response)
            return None
        if response.status != 200:
            raise self._failed("GET", path, response)
        try:
            data = response.read(_MAX_RECORD + 1)
        except (OSError, http.client.HTTPException) as error:
            self._drop_connection()
            raise CacheUnavailable(f"{self.display}: {_describe(error)}") from None
        self._finish(response)
        return data if len(data) <= _MAX_RECORD else None

    def has_blob(self, digest: str) -> bool:
        path = f"/cas/{digest}"
        response = self._send("HEAD", path, None, {})
        self._finish(response)
        if response.status in (200, 204):
            return True
        if response.status == 404:
            return False
        raise self._failed("HEAD", path, response)

    def fetch_blob(self, digest: str, out: BinaryIO) -> bool:
        """Stream /cas/<digest> into `out`; False when the server has no such blob."""
        path = f"/cas/{digest}"
        response = self._send("GET", path, None, {})
        if response.status == 404:
            self._finish(response)
            return False
        if response.status != 200:
            raise self._failed("GET", path, response)
        announced = response.getheader("Content-Length")
        received = 0
        try:
            while chunk := response.read(_CHUNK):
                out.write(chunk)
                received += len(chunk)
            if announced is not None and announced.isdigit() and received != int(announced):
                raise http.client.IncompleteRead(b"", int(announced) - received)
        except http.client.IncompleteRead:
            self._drop_connection()
            raise TruncatedDownload(f"{self.display}: /cas/{digest} ended early") from None
        except (OSError, http.client.HTTPException) as error:
            self._drop_connection()
            raise CacheUnavailable(f"{self.display}: {_describe(error)}") from None
        self._finish(response)
        return True

    def put_blob(self, digest: str, source: Path) -> None:
        path = f"/cas/{digest}"
        with open(source, "rb") as handle:
            size = os.fstat(handle.fileno()).st_size
            response = self._send("PUT", path, handle, {
                "Content-Type": "application/octet-stream", "Content-Length": str(size)})
        if response.status not in (200, 201, 204):
            raise self._failed("PUT", path, response)
        self._finish(response)

    def put_action(self, address: str, data: bytes) -> None:
        path = f"/ac/{address}"
        response = self._send("PUT", path, data, {
            "Content-Type": "application/json", "Content-Length": str(len(data))})
        if response.status not in (200, 201, 204):
            raise self._failed("PUT", path, response)
        self._finish(response)


def _describe(error: BaseException) -> str:
    if isinstance(error, (socket.timeout, TimeoutError)):
        return "timed out"
    if isinstance(error, OSError) and error.strerror:
        return error.strerror.lower()
    return str(error) or type(error).__name__
