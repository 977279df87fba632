"""The HTTP cache tier against a real nginx with WebDAV: round trips, credentials, poisoned
entries, a server that stops or never answers, read-only runs and servers refusing uploads."""

from __future__ import annotations

import hashlib
import http.server
import io
import json
import socket
import tarfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import zstandard

from nginx_server import NginxServer, nginx, nginx_no_put  # noqa: F401 (fixtures)
from wsbuild.cache.client import BuildCache
from wsbuild.cache.http import HttpCache
from wsbuild.cache.settings import redact
from wsbuild.cache.key import CacheKey
from wsbuild.cache.local import LocalCache
from wsbuild.cache.action_result import ActionResult, parse_action_result

def key_for(name: str) -> CacheKey:
    return CacheKey(name, f'{{"package":"{name}"}}')


def install_tree(root: Path, text: str = "payload") -> Path:
    (root / "share" / "pkg").mkdir(parents=True, exist_ok=True)
    (root / "share" / "pkg" / "file.txt").write_text(text)
    return root


def client(tmp_path: Path, url: str, name: str, **kwargs: object) -> tuple[BuildCache, list[str]]:
    warnings: list[str] = []
    remote = HttpCache(url, environ={}, timeout=kwargs.pop("timeout", 3.0))  # type: ignore[arg-type]
    return BuildCache(LocalCache(tmp_path / name), remote, warn=warnings.append,
                      **kwargs), warnings  # type: ignore[arg-type]


def test_round_trip_through_nginx(tmp_path: Path, nginx: NginxServer) -> None:
    writer, warnings = client(tmp_path, nginx.url, "machine1")
    assert writer.store(key_for("pkg"), install_tree(tmp_path / "install")) is None
    writer.close()
    assert warnings == []
    assert [p.name for p in nginx.stored("ac")] == [key_for("pkg").address]
    record = parse_action_result(nginx.stored("ac")[0].read_bytes())
    assert record is not None and [p.name for p in nginx.stored("cas")] == [record.digest]
    # the record is an ActionResult in JSON, as bazel-remote expects
    assert json.loads(nginx.stored("ac")[0].read_text())["outputFiles"][0]["digest"]["hash"] == record.digest

    reader, warnings = client(tmp_path, nginx.url, "machine2")
    stage = tmp_path / "stage"
    stage.mkdir()
    restored = reader.restore(key_for("pkg"), stage)
    assert restored is not None and restored.source == nginx.url.rstrip("/")
    assert (stage / "share" / "pkg" / "file.txt").read_text() == "payload"
    assert warnings == []
    # kept locally: the next restore needs no network
    requests = len(nginx.requests())
    again = reader.restore(key_for("pkg"), tmp_path / "stage2")
    assert again is not None and again.source == "local" and len(nginx.requests()) == requests


def test_upload_skips_blobs_the_server_has(tmp_path: Path, nginx: NginxServer) -> None:
    one, _ = client(tmp_path, nginx.url, "one")
    one.store(key_for("pkg"), install_tree(tmp_path / "install"))
    one.close()
    two, _ = client(tmp_path, nginx.url, "two")
    two.store(key_for("pkg"), tmp_path / "install")
    two.close()
    puts = [line for line in nginx.requests() if line.startswith("PUT /cas/")]
    assert len(puts) == 1


def test_bearer_token_and_netrc_are_sent_never_shown(tmp_path: Path, nginx: NginxServer) -> None:
    remote = HttpCache(nginx.url, environ={"WSBUILD_CACHE_TOKEN": "s3cret-token"})
    assert remote.get_action("0" * 64) is None
    netrc = tmp_path / "netrc"
    netrc.write_text("machine 127.0.0.1 login ci password hunter2\n")
    netrc.chmod(0o600)
    HttpCache(nginx.url, environ={"NETRC": str(netrc)}).get_action("1" * 64)
    log = nginx.requests(at_least=2)
    assert log[0].endswith("auth=Bearer s3cret-token")
    assert log[1].endswith("auth=Basic Y2k6aHVudGVyMg==")  # ci:hunter2
    assert "s3cret" not in remote.display
    assert redact("http://user:pw@host:81/c") == "http://host:81/c"


def put_remote(server: NginxServer, kind: str, name: str, data: bytes) -> None:
    path = server.root / kind / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)


def bad_archive() -> bytes:
    raw = io.BytesIO()
    with tarfile.open(fileobj=raw, mode="w") as tar:
        info = tarfile.TarInfo("../escaped")
        info.size = 4
        tar.addfile(info, io.BytesIO(b"evil"))
    return zstandard.ZstdCompressor().compress(raw.getvalue())


def poison(server: NginxServer, key: CacheKey, case: str) -> None:
    good = b"\x28\xb5\x2f\xfd" + b"x" * 100
    digest = hashlib.sha256(good).hexdigest()
    if case == "wrong-digest":
        put_remote(server, "cas", digest, b"something else entirely")
        put_remote(server, "ac", key.address, ActionResult(key.package, digest, len(good)).encode())
    elif case == "wrong-size":
        put_remote(server, "cas", digest, good)
        put_remote(server, "ac", key.address, ActionResult(key.package, digest, len(good) + 5).encode())
    elif case == "not-a-record":
        put_remote(server, "ac", key.address, b"<html>nope</html>")
    elif case == "other-package":
        put_remote(server, "cas", digest, good)
        put_remote(server, "ac", key.address, ActionResult("other", digest, len(good)).encode())
    elif case == "escaping-member":
        data = bad_archive()
        digest = hashlib.sha256(data).hexdigest()
        put_remote(server, "cas", digest, data)
        put_remote(server, "ac", key.address, ActionResult(key.package, digest, len(data)).encode())
    elif case == "not-an-archive":
        data = b"just some bytes"
        digest = hashlib.sha256(data).hexdigest()
        put_remote(server, "cas", digest, data)
        put_remote(server, "ac", key.address, ActionResult(key.package, digest, len(data)).encode())


@pytest.mark.parametrize("case", ["wrong-digest", "wrong-size", "not-a-record", "other-package",
                                  "escaping-member", "not-an-archive"])
def test_poisoned_remote_entries_are_refused_with_one_warning(tmp_path: Path, nginx: NginxServer,
                                                              case: str) -> None:
    poison(nginx, key_for("pkg"), case)
    cache, warnings = client(tmp_path, nginx.url, "local")
    stage = tmp_path / "ws" / "install" / "stage"
    stage.mkdir(parents=True)
    assert cache.restore(key_for("pkg"), stage) is None
    assert len(warnings) == 1 and warnings[0].startswith("cache entry for pkg refused (")
    assert not (tmp_path / "ws" / "install" / "escaped").exists()
    assert sorted(p.name for p in (tmp_path / "ws" / "install").iterdir()) == ["stage"]
    # nothing of it was kept locally
    for kind in ("cas", "ac", "tmp"):
        assert not (tmp_path / "local" / kind).exists() or not any((tmp_path / "local" / kind).iterdir())


class _Truncating(http.server.BaseHTTPRequestHandler):
    record = b""

    def do_GET(self) -> None:  # noqa: N802 (http.server's naming)
        if self.path.startswith("/ac/"):
            body = self.record
            self.send_response(200)
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)
        else:
            self.send_response(200)
            self.send_header("Content-Length", "100000")
            self.end_headers()
            self.wfile.write(b"x" * 100)
            self.close_connection = True

    def log_message(self, *args: object) -> None:
        pass


@pytest.fixture
def truncating_server() -> Iterator[str]:
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Truncating)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


def test_truncated_download_is_refused(tmp_path: Path, truncating_server: str) -> None:
    _Truncating.record = ActionResult("pkg", "a" * 64, 100000).encode()
    cache, warnings = client(tmp_path, truncating_server, "local")
    assert cache.restore(key_for("pkg"), tmp_path / "stage") is None
    assert warnings == ["cache entry for pkg refused (truncated download); building it"]
    assert not any((tmp_path / "local" / "tmp").iterdir())


def test_server_stopped_mid_run_turns_the_remote_off_with_one_warning(tmp_path: Path,
                                                                       nginx: NginxServer) -> None:
    cache, warnings = client(tmp_path, nginx.url, "local")
    cache.store(key_for("a"), install_tree(tmp_path / "a"))
    nginx.stop()
    assert cache.restore(key_for("b"), tmp_path / "sb") is None
    assert cache.restore(key_for("c"), tmp_path / "sc") is None
    cache.store(key_for("d"), install_tree(tmp_path / "d"))
    cache.close()
    assert len(warnings) == 1 and "the remote cache is off for this run" in warnings[0]
    assert "s3cret" not in warnings[0]
    # the local tier still works
    assert cache.restore(key_for("d"), tmp_path / "sd") is not None


def test_a_server_that_never_answers_costs_one_short_timeout(tmp_path: Path) -> None:
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(16)  # accepts connections into the backlog, never answers
        url = f"http://127.0.0.1:{silent.getsockname()[1]}/"
        cache, warnings = client(tmp_path, url, "local", timeout=0.5)
        started = time.monotonic()
        for name in ("a", "b", "c", "d"):
            assert cache.restore(key_for(name), tmp_path / name) is None
        assert time.monotonic() - started < 3 * 0.5
        assert len(warnings) == 1 and "timed out" in warnings[0]


def test_read_only_reads_but_never_writes(tmp_path: Path, nginx: NginxServer) -> None:
    writer, _ = client(tmp_path, nginx.url, "writer")
    writer.store(key_for("pkg"), install_tree(tmp_path / "install"))
    writer.close()
    before = nginx.stored("cas") + nginx.stored("ac")
    # nginx logs a request after answering it: wait for the writer's uploads (one PUT per
    # stored file) to be logged before counting
    deadline = time.monotonic() + 10
    while sum(line.startswith("PUT") for line in nginx.requests()) < len(before) \
            and time.monotonic() < deadline:
        time.sleep(0.02)
    puts = sum(line.startswith("PUT") for line in nginx.requests())
    reader, warnings = client(tmp_path, nginx.url, "reader", read_only=True)
    assert reader.restore(key_for("pkg"), tmp_path / "stage") is not None
    assert reader.store(key_for("new"), install_tree(tmp_path / "new")) is not None
    reader.close()
    assert nginx.stored("cas") + nginx.stored("ac") == before
    assert sum(line.startswith("PUT") for line in nginx.requests()) == puts
    assert not any((tmp_path / "reader" / "ac").iterdir())
    assert warnings == []


def test_a_server_refusing_uploads_warns_once_and_keeps_building(tmp_path: Path,
                                                                 nginx_no_put: NginxServer) -> None:
    cache, warnings = client(tmp_path, nginx_no_put.url, "local")
    for name in ("a", "b", "c"):
        assert cache.store(key_for(name), install_tree(tmp_path / name)) is None
    cache.close()
    assert len(warnings) == 1 and "refuses uploads" in warnings[0] and "405" in warnings[0]
    assert cache.restore(key_for("c"), tmp_path / "sc") is not None  # stored locally anyway


def test_concurrent_writers_of_one_entry_leave_one_good_entry(tmp_path: Path,
                                                              nginx: NginxServer) -> None:
    sources = [install_tree(tmp_path / f"src{i}", f"payload {i}" * 1000) for i in range(4)]
    writers = [client(tmp_path, nginx.url, f"machine{i}")[0] for i in range(4)]
    threads = [threading.Thread(target=w.store, args=(key_for("pkg"), s))
               for w, s in zip(writers, sources)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for writer in writers:
        writer.close()
    reader, warnings = client(tmp_path, nginx.url, "reader")
    stage = tmp_path / "stage"
    assert reader.restore(key_for("pkg"), stage) is not None and warnings == []
    assert (stage / "share" / "pkg" / "file.txt").read_text() in [
        (s / "share" / "pkg" / "file.txt").read_text() for s in sources]
