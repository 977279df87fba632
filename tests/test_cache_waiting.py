"""cache/waiting.py: waiting for a package another job builds ends when its entry is there
and proved, when it is there but of another build, when the server is gone, when the caller
gives up, or at the deadline; never later. A fake cache and a fake clock (pure logic)."""

from __future__ import annotations

from collections.abc import Mapping

from wsbuild.cache.key import CacheKey
from wsbuild.cache.run import Proven
from wsbuild.cache.waiting import LOOKS_AT_MOST_EVERY, wait_for_entry
from wsbuild.record.outside import Digests

KEY = CacheKey("pkg", "{}")


class Clock:
    def __init__(self) -> None:
        self.now = 100.0
        self.slept: list[float] = []

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.now += seconds


class Cache:
    """Answers `probe` from a script: None (not there yet) until the given look."""

    def __init__(self, answers: Mapping[int, object], clock: Clock) -> None:
        self.answers = answers
        self.looks = 0
        self.clock = clock

    def probe(self, key: CacheKey, inputs_key: str, dependencies: Mapping[str, str],
              digests: Digests) -> object:
        self.looks += 1
        return self.answers.get(self.looks)


def _wait(answers: Mapping[int, object], *, until: float = 130.0, give_up=lambda: ""):
    clock = Clock()
    cache = Cache(answers, clock)
    waited = wait_for_entry(cache, KEY, "inputs", {}, Digests(), until=until,  # type: ignore[arg-type]
                            give_up=give_up, clock=clock, sleep=clock.sleep)
    return waited, cache, clock


def test_the_entry_is_taken_as_soon_as_it_is_there() -> None:
    proven = Proven(found=None, record=None)  # type: ignore[arg-type]
    waited, cache, clock = _wait({4: proven})
    assert waited.proven is proven and waited.looks == 4 == cache.looks
    assert abs(waited.seconds - sum(clock.slept)) < 1e-9 and waited.seconds < 1.0  # quick


def test_the_wait_ends_at_its_deadline_and_looks_at_most_every_two_seconds() -> None:
    waited, cache, clock = _wait({}, until=130.0)
    assert waited.proven is None and waited.why_not == "not in the cache after 30.0 s"
    assert clock.now == 130.0 and max(clock.slept) <= LOOKS_AT_MOST_EVERY


def test_another_builds_entry_or_a_server_gone_end_it_at_once() -> None:
    waited, cache, _ = _wait({2: "built against another build of dep"})
    assert waited.why_not == "built against another build of dep" and cache.looks == 2
    waited, cache, _ = _wait({1: "the cache server is off for this run"})
    assert waited.why_not == "the cache server is off for this run" and cache.looks == 1


def test_the_caller_may_give_up() -> None:
    answers = iter(["", "", "shard 1/2 planned another workspace"])
    waited, cache, _ = _wait({}, give_up=lambda: next(answers))
    assert waited.why_not == "shard 1/2 planned another workspace" and cache.looks == 3
