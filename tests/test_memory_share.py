"""builder/resources/memory.py: what each package needed in memory, shared by the jobs of a CI matrix
through the cache server as they share the times (a real nginx)."""

from __future__ import annotations

from pathlib import Path

from nginx_server import NginxServer, nginx  # noqa: F401 (fixture)
from wsbuild.builder.resources.memory import publish_memory, shared_memory
from wsbuild.cache.documents import SharedDocuments
from wsbuild.cache.settings import CacheSettings
from wsbuild.engine.memory_records import PackageMemoryRecord, StepMemory, record_memory

M = 1024 * 1024


def _record(job: int, jobs: int) -> PackageMemoryRecord:
    return PackageMemoryRecord(job + 20 * M, {"build": StepMemory(job + 20 * M, job, jobs)})


def test_the_jobs_of_a_matrix_share_what_their_packages_needed(nginx: NginxServer,
                                                               tmp_path: Path) -> None:
    settings = CacheSettings(url=nginx.url, timeout=1.0)
    first, second = tmp_path / "job1" / "build", tmp_path / "job2" / "build"
    record_memory(first, {"a": _record(300 * M, 8), "b": _record(100 * M, 4)})
    record_memory(second, {"c": _record(500 * M, 6), "a": _record(200 * M, 1)})
    # each job publishes what it built; a's one-file build only raises what was shared
    assert publish_memory(settings, ["a", "b"], first) == []
    assert publish_memory(settings, ["c", "a"], second) == []
    documents = SharedDocuments.open(settings)
    assert documents is not None
    try:
        shared = shared_memory(documents)
    finally:
        documents.close()
    assert sorted(shared) == ["a", "b", "c"]
    assert shared["a"].job == 300 * M and shared["c"].job == 500 * M
    assert shared_memory(None) == {}
