"""`wsbuild cache stats|prune|verify`: the local build cache (~/.cache/wsbuild)."""

from __future__ import annotations

import argparse
import os
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the cache modules are imported when an action runs, not to parse
    from wsbuild.cache.local import LocalCache

CACHE_DOC = """Look after the local build cache.

`wsbuild build` stores every package it builds in $XDG_CACHE_HOME/wsbuild (default
~/.cache/wsbuild) and restores it from there, or from the HTTP server named by --cache /
WSBUILD_CACHE, whenever the same package is built again with the same sources, options,
dependencies, underlay, compilers and install path. `stats` shows its size, `prune` evicts
the least recently used entries (builds do so above WSBUILD_CACHE_MAX_SIZE, default 5G),
`verify` checks every archive against its digest and removes bad entries.
"""


def add_prune_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--max-size", metavar="SIZE",
                        help="evict until the cache fits SIZE, e.g. 2G (0 empties it; default: "
                             "$WSBUILD_CACHE_MAX_SIZE or 5G)")


def _size(count: int) -> str:
    value = float(count)
    for unit in ("B", "KiB", "MiB", "GiB"):
        if value < 1024 or unit == "GiB":
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1024
    return f"{count} B"


def _local() -> tuple[LocalCache, str | None]:
    from wsbuild.cache.local import LocalCache  # lazy: off Tab completion and `--help`
    from wsbuild.cache.settings import settings_from_environment  # lazy: off Tab completion

    settings = settings_from_environment(os.environ)
    assert settings.directory is not None
    return LocalCache(settings.directory, settings.max_bytes), settings.url


def run_stats(args: argparse.Namespace) -> int:
    """How many entries the local cache holds and how much space they take."""
    local, url = _local()
    stats = local.stats()
    print(f"local cache: {stats.directory}")
    print(f"  {stats.entries} entries, {stats.blobs} blobs (archives and package records), "
          f"{_size(stats.bytes)} "
          f"of {_size(stats.max_bytes)} (WSBUILD_CACHE_MAX_SIZE)")
    if url:
        from wsbuild.cache.settings import redact  # lazy: off Tab completion and `--help`

        print(f"remote cache: {redact(url)} (WSBUILD_CACHE)")
    return 0


def run_prune(args: argparse.Namespace) -> int:
    """Evict the least recently used entries until the local cache fits its size limit."""
    local, _ = _local()
    from wsbuild.cache.settings import parse_size  # lazy: off Tab completion and `--help`

    limit = parse_size(args.max_size) if args.max_size is not None else local.max_bytes
    pruned = local.prune(limit)
    print(f"removed {pruned.blobs} blobs and {pruned.entries} entries, "
          f"freed {_size(pruned.bytes)}; {_size(local.stats().bytes)} left in {local.root}")
    return 0


def run_verify(args: argparse.Namespace) -> int:
    """Check every blob against its digest and every entry against its archive and package
    record; remove what is bad. Exit 1 when anything was bad."""
    local, _ = _local()
    problems = local.verify()
    for problem in problems:
        print(f"{local.root}/{problem}")
    stats = local.stats()
    print(f"{stats.entries} entries, {stats.blobs} blobs checked in {local.root}: "
          f"{len(problems)} problem(s)")
    return 1 if problems else 0
