"""Waiting for a package another job of a CI matrix builds: its entry is looked up again and
again (`RunCache.probe`) until it is there and proved, until a deadline, or until the caller
gives up (builder/shards/run.py: the other job planned another workspace). Every wait is
bounded; the looks grow from a fifth of a second to two seconds apart."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from wsbuild.cache.run import Proven, RunCache

if TYPE_CHECKING:
    from wsbuild.cache.key import CacheKey
    from wsbuild.record.outside import Digests

FIRST_LOOK_AFTER = 0.2
LOOKS_AT_MOST_EVERY = 2.0


@dataclass(frozen=True, slots=True)
class Waited:
    """How a wait ended: the entry proved (`proven`), else why not."""

    proven: Proven | None
    why_not: str
    seconds: float
    looks: int


def wait_for_entry(cache: RunCache, key: CacheKey, inputs_key: str,
                   dependencies: Mapping[str, str], digests: Digests, *, until: float,
                   give_up: Callable[[], str] = lambda: "",
                   clock: Callable[[], float] = time.monotonic,
                   sleep: Callable[[float], None] = time.sleep) -> Waited:
    """Look for `key`'s entry until `until` (a `clock` time). An entry that is there but not
    of this build (`disproof`) ends the wait at once, as does a server that went off or a
    reason `give_up` returns."""
    started = clock()
    pause = FIRST_LOOK_AFTER
    looks = 0
    while True:
        looks += 1
        found = cache.probe(key, inputs_key, dependencies, digests)
        if isinstance(found, Proven):
            return Waited(found, "", clock() - started, looks)
        if isinstance(found, str):
            return Waited(None, found, clock() - started, looks)
        why = give_up()
        if why:
            return Waited(None, why, clock() - started, looks)
        now = clock()
        if now >= until:
            return Waited(None, f"not in the cache after {now - started:.1f} s",
                          now - started, looks)
        sleep(min(pause, until - now))
        pause = min(LOOKS_AT_MOST_EVERY, pause * 1.5)
