"""The local cache tier: entries survive, least recently used go first, corruption is found,
and concurrent writers leave one good entry."""

from __future__ import annotations

import multiprocessing
import os
import time
from pathlib import Path

import pytest

from wsbuild.cache.client import BuildCache
from wsbuild.cache.settings import default_cache_dir, parse_size, settings_from_environment
from wsbuild.cache.key import CacheKey, cache_key
from wsbuild.cache.local import LocalCache
from wsbuild.errors import WsbuildError


def key_for(name: str, build_key: str = "b1") -> CacheKey:
    return CacheKey(name, f'{{"package":"{name}","build_key":"{build_key}"}}')


def install_tree(root: Path, payload: bytes = b"x" * 1000) -> Path:
    (root / "share" / "pkg").mkdir(parents=True, exist_ok=True)
    (root / "share" / "pkg" / "data.bin").write_bytes(payload)
    return root


def test_store_then_restore_in_a_fresh_stage(tmp_path: Path) -> None:
    cache = BuildCache(LocalCache(tmp_path / "cache"))
    source = install_tree(tmp_path / "install")
    assert cache.store(key_for("pkg"), source) is None
    stage = tmp_path / "stage"
    stage.mkdir()
    restored = cache.restore(key_for("pkg"), stage)
    assert restored is not None and restored.source == "local"
    assert (stage / "share" / "pkg" / "data.bin").read_bytes() == b"x" * 1000
    assert cache.restore(key_for("pkg", "other build"), tmp_path / "stage2") is None


def test_default_directory_follows_xdg(tmp_path: Path) -> None:
    assert default_cache_dir({"XDG_CACHE_HOME": str(tmp_path)}) == tmp_path / "wsbuild"
    assert default_cache_dir({}) == Path.home() / ".cache" / "wsbuild"
    settings = settings_from_environment({"XDG_CACHE_HOME": str(tmp_path),
                                          "WSBUILD_CACHE": "http://cache.example:8080/",
                                          "WSBUILD_CACHE_MAX_SIZE": "2G"})
    assert settings.url == "http://cache.example:8080" and settings.max_bytes == 2 * 1024**3
    assert settings_from_environment({}, url="https://x/", no_cache=True).enabled is False
    assert settings_from_environment({"WSBUILD_CACHE": "off"}).enabled is False
    assert settings_from_environment({"WSBUILD_CACHE": "off"}, url="http://x/").enabled is True
    with pytest.raises(WsbuildError, match="unsupported cache URL"):
        settings_from_environment({"WSBUILD_CACHE": "ftp://user:secret@host/"})


def test_url_credentials_never_show(tmp_path: Path) -> None:
    with pytest.raises(WsbuildError) as raised:
        settings_from_environment({}, url="ftp://user:secret@host/")
    assert "secret" not in str(raised.value)


@pytest.mark.parametrize("text,expected", [("1024", 1024), ("5G", 5 * 1024**3),
                                           ("500M", 500 * 1024**2), ("1.5GiB", int(1.5 * 1024**3))])
def test_parse_size(text: str, expected: int) -> None:
    assert parse_size(text) == expected


def test_prune_evicts_least_recently_used(tmp_path: Path) -> None:
    local = LocalCache(tmp_path / "cache")
    cache = BuildCache(local)
    for index, name in enumerate(["old", "used", "new"]):
        cache.store(key_for(name), install_tree(tmp_path / name, os.urandom(20000)))
        for path in list(local.cas.iterdir()) + list(local.ac.iterdir()):
            if time.time() - path.stat().st_mtime < 50:
                os.utime(path, (time.time() - 1000 + index * 100,) * 2)
    # using "used" makes it the most recently used
    assert cache.restore(key_for("used"), tmp_path / "s1") is not None
    size_one = max(p.stat().st_size for p in local.cas.iterdir())
    pruned = local.prune(max_bytes=2 * size_one)
    assert pruned.blobs == 1 and pruned.entries == 1
    assert cache.restore(key_for("old"), tmp_path / "s2") is None
    assert cache.restore(key_for("used"), tmp_path / "s3") is not None
    assert cache.restore(key_for("new"), tmp_path / "s4") is not None
    assert local.stats().blobs == 2


def test_close_keeps_the_cache_within_its_limit(tmp_path: Path) -> None:
    local = LocalCache(tmp_path / "cache", max_bytes=30000)
    cache = BuildCache(local)
    for name in ("a", "b", "c", "d"):
        cache.store(key_for(name), install_tree(tmp_path / name, os.urandom(20000)))
    cache.close()
    assert local.stats().bytes <= 30000 and local.stats().blobs == 1


def test_verify_finds_and_removes_corrupt_entries(tmp_path: Path) -> None:
    local = LocalCache(tmp_path / "cache")
    cache = BuildCache(local)
    cache.store(key_for("good"), install_tree(tmp_path / "good"))
    cache.store(key_for("bad"), install_tree(tmp_path / "bad", b"y" * 3000))
    bad_blob = local.cas / _record_digest(local, key_for("bad"))
    bad_blob.write_bytes(b"corrupted")
    (local.ac / ("0" * 64)).write_text("garbage")
    problems = local.verify()
    assert any("does not match" in p for p in problems)
    assert any("not a wsbuild cache record" in p for p in problems)
    assert any("missing" in p for p in problems)
    assert local.verify() == []
    assert cache.restore(key_for("good"), tmp_path / "s") is not None


def _record_digest(local: LocalCache, key: CacheKey) -> str:
    from wsbuild.cache.action_result import parse_action_result

    record = parse_action_result((local.ac / key.address).read_bytes())
    assert record is not None
    return record.digest


def test_a_corrupted_local_entry_is_refused_once_then_forgotten(tmp_path: Path) -> None:
    warnings: list[str] = []
    local = LocalCache(tmp_path / "cache")
    cache = BuildCache(local, warn=warnings.append)
    cache.store(key_for("pkg"), install_tree(tmp_path / "install"))
    blob = local.cas / _record_digest(local, key_for("pkg"))
    blob.write_bytes(blob.read_bytes()[:-10])
    assert cache.restore(key_for("pkg"), tmp_path / "s1") is None
    assert warnings == ["cache entry for pkg refused (archive does not match its digest); building it"]
    assert cache.restore(key_for("pkg"), tmp_path / "s2") is None
    assert len(warnings) == 1  # forgotten: a plain miss now


def test_read_only_cache_writes_nothing(tmp_path: Path) -> None:
    cache = BuildCache(LocalCache(tmp_path / "cache"), read_only=True)
    assert cache.store(key_for("pkg"), install_tree(tmp_path / "install")) is not None
    assert not (tmp_path / "cache" / "ac").exists() or not any((tmp_path / "cache" / "ac").iterdir())


def _store_many(root: str, source: str, rounds: int) -> None:
    cache = BuildCache(LocalCache(Path(root)))
    for index in range(rounds):
        # every writer packs different bytes (mtimes differ) under the same key
        os.utime(Path(source, "share", "pkg", "data.bin"), (index, index + os.getpid()))
        cache.store(key_for("pkg"), Path(source))


def test_concurrent_writers_leave_one_good_entry(tmp_path: Path) -> None:
    sources = [install_tree(tmp_path / f"src{i}", os.urandom(200000)) for i in range(4)]
    context = multiprocessing.get_context("fork")
    writers = [context.Process(target=_store_many, args=(str(tmp_path / "cache"), str(s), 15))
               for s in sources]
    for writer in writers:
        writer.start()
    for writer in writers:
        writer.join(60)
        assert writer.exitcode == 0
    local = LocalCache(tmp_path / "cache")
    assert local.verify() == []
    stage = tmp_path / "stage"
    stage.mkdir()
    assert BuildCache(local).restore(key_for("pkg"), stage) is not None
    payload = (stage / "share" / "pkg" / "data.bin").read_bytes()
    assert payload in [(s / "share" / "pkg" / "data.bin").read_bytes() for s in sources]
    assert not any(local.tmp.iterdir())


def test_cache_key_covers_inputs_key_version_and_the_variables_read() -> None:
    """The key holds what is known before a build (the inputs key, which holds the install
    prefix: test_cache_build.py's other install base); the variables its steps were observed
    to read (CXX among them) pick a variant of it, by their digests."""
    base = dict(package="pkg", inputs_key="k", build_type="ament_cmake", version="1")
    key = cache_key(**base)
    assert key == cache_key(**base)
    assert len(key.address) == 64
    others = [{**base, "inputs_key": "k2"}, {**base, "version": "2"}]
    assert len({key.address, *(cache_key(**o).address for o in others)}) == 3
    gcc, clang = key.with_variant({"CXX": "digest-of-g++"}), key.with_variant({"CXX": "other"})
    assert len({key.address, gcc.address, clang.address}) == 3
    assert gcc.addresses[0] == key.address == clang.addresses[0]
