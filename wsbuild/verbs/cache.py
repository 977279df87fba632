"""`wsbuild cache stats|prune|verify`: the local build cache (~/.cache/wsbuild)."""

from __future__ import annotations

import argparse
import os

from wsbuild.cache.local import LocalCache
from wsbuild.cache.settings import parse_size, redact, settings_from_environment


def _size(count: int) -> str:
    value = float(count)
    for unit in ("B", "KiB", "MiB", "GiB"):
        if value < 1024 or unit == "GiB":
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1024
    return f"{count} B"


def _local() -> tuple[LocalCache, str | None]:
    settings = settings_from_environment(os.environ)
    assert settings.directory is not None
    return LocalCache(settings.directory, settings.max_bytes), settings.url


def run_stats(args: argparse.Namespace) -> int:
    """How many entries the local cache holds and how much space they take."""
    local, url = _local()
    stats = local.stats()
    print(f"local cache: {stats.directory}")
    print(f"  {stats.entries} entries, {stats.blobs} archives, {_size(stats.bytes)} "
          f"of {_size(stats.max_bytes)} (WSBUILD_CACHE_MAX_SIZE)")
    if url:
        print(f"remote cache: {redact(url)} (WSBUILD_CACHE)")
    return 0


def run_prune(args: argparse.Namespace) -> int:
    """Evict the least recently used entries until the local cache fits its size limit."""
    local, _ = _local()
    limit = parse_size(args.max_size) if args.max_size is not None else local.max_bytes
    pruned = local.prune(limit)
    print(f"removed {pruned.blobs} archives and {pruned.entries} entries, "
          f"freed {_size(pruned.bytes)}; {_size(local.stats().bytes)} left in {local.root}")
    return 0


def run_verify(args: argparse.Namespace) -> int:
    """Check every archive against its digest and every entry against its archive; remove
    what is bad. Exit 1 when anything was bad."""
    local, _ = _local()
    problems = local.verify()
    for problem in problems:
        print(f"{local.root}/{problem}")
    stats = local.stats()
    print(f"{stats.entries} entries, {stats.blobs} archives checked in {local.root}: "
          f"{len(problems)} problem(s)")
    return 1 if problems else 0
