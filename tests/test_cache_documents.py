"""cache/documents.py: the small documents the jobs of a CI matrix share on the cache server
(recorded times, each shard's note), against a real nginx: written and read back, replaced
whole, none when absent or not what they should be, one line when the server is gone."""

from __future__ import annotations

from pathlib import Path

from nginx_server import NginxServer, nginx  # noqa: F401 (fixture)
from nginx_server import free_port
from wsbuild.cache.documents import SharedDocuments, document_address
from wsbuild.cache.settings import CacheSettings


def _documents(url: str) -> SharedDocuments:
    documents = SharedDocuments.open(CacheSettings(url=url, timeout=1.0))
    assert documents is not None
    return documents


def test_a_document_is_written_read_back_and_replaced_whole(nginx: NginxServer,
                                                            tmp_path: Path) -> None:
    documents = _documents(nginx.url)
    assert documents.get("package times") is None
    assert documents.put("package times", {"times": {"a": 1.5}}, "times", tmp_path)
    assert documents.get("package times") == {"times": {"a": 1.5}, "format": 1}
    assert documents.put("package times", {"times": {"b": 2.0}}, "times", tmp_path)
    assert documents.get("package times") == {"times": {"b": 2.0}, "format": 1}
    # an action record and a blob in the layout bazel-remote serves; nothing left behind here
    assert (nginx.root / "ac" / document_address("package times")).is_file()
    assert list(tmp_path.iterdir()) == []
    assert documents.problems == []
    documents.close()


def test_a_document_that_is_not_what_it_should_be_reads_as_none(nginx: NginxServer,
                                                                 tmp_path: Path) -> None:
    documents = _documents(nginx.url)
    assert documents.put("note", {"shard": 1}, "note", tmp_path)
    record = nginx.root / "ac" / document_address("note")
    blob = next(p for p in nginx.stored("cas"))
    blob.write_bytes(b'{"format": 1, "shard": 2}')  # not the bytes its digest names
    assert documents.get("note") is None
    record.write_bytes(b'{"outputFiles": [{"path": "../../etc/passwd", "digest": {}}]}')
    assert documents.get("note") is None
    record.write_bytes(b"not json")
    assert documents.get("note") is None
    documents.close()


def test_a_server_that_is_gone_costs_one_line(tmp_path: Path) -> None:
    documents = _documents(f"http://127.0.0.1:{free_port()}/")
    assert documents.get("package times") is None
    assert not documents.put("package times", {"times": {}}, "times", tmp_path)
    assert len(documents.problems) == 2
    assert documents.problems[0].startswith("could not read package times: ")
    documents.close()
