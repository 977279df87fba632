"""Whether a package's last passing test result still holds, asked as the dirty check asks it
of a build (record/dirty.py), and answered with its typed `Reason`: the result's key
(`TestKey`: digests of what the tests can observe that is known before they run, each part
derived from the packages' records; testing/test_key.py makes it), and what its run was
observed to read (`TestRun`: the files, listings and variables, as a build's record holds its
steps'). `wsbuild test --dry-run` prints the reason as `build --dry-run` prints a build's."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from wsbuild.record.dirty import Dirty, Reason
from wsbuild.record.environment import changed_names, variable_digests
from wsbuild.record.outside import Digests, OutsideReads, first_change


@dataclass(frozen=True, slots=True)
class TestKey:
    """Everything a package's tests can observe known before they run, as digests
    (testing/cached_result.py's docstring tells each part)."""

    __test__ = False  # not a pytest test class

    build: str
    closure: dict[str, str]
    sources: str
    options: str
    tools: str
    underlays: str = ""

    def changed_since(self, old: TestKey) -> Reason | None:
        """What changed from `old` (the first of the parts, in the key's order)."""
        if self.build != old.build:
            return Reason(Dirty.REBUILT, "the package was rebuilt")
        if self.closure != old.closure:
            names = tuple(sorted(n for n in set(self.closure) | set(old.closure)
                                 if self.closure.get(n) != old.closure.get(n)))
            return Reason(Dirty.DEPENDENCY, f"rebuilt on its test environment: {' '.join(names)}",
                          details=names)
        if self.underlays != old.underlays:
            return Reason(Dirty.EXTERNAL,
                          "an underlay workspace's package it runs against changed")
        if self.sources != old.sources:
            return Reason(Dirty.SOURCE, "a file of the package changed")
        if self.options != old.options:
            return Reason(Dirty.OPTIONS, "other test options")
        if self.tools != old.tools:
            return Reason(Dirty.EXTERNAL, "the test tools or the installed distributions changed")
        return None


@dataclass(frozen=True, slots=True)
class TestRun:
    """What a passing test run left to compare with: its key, what it was observed to read,
    and whether its result files are still the ones it wrote."""

    __test__ = False  # not a pytest test class

    key: TestKey
    reads: OutsideReads = field(default_factory=OutsideReads)
    #: the variables it read, by their values' digests as it saw them
    environment: Mapping[str, str] = field(default_factory=dict)
    #: why it was not fully observed (such a result never holds)
    unobserved: tuple[str, ...] = ()
    results_kept: bool = True


def rerun_reason(key: TestKey | None, last: TestRun | None, *,
                 environ: Mapping[str, str] | None = None, own_install: str = "",
                 ignored: tuple[str, ...] = (), forced: bool = False) -> Reason | None:
    """Why the package's tests run again rather than reuse `last` (None: `last` holds).
    `key`: the key now (None: a package of the test closure has no record); `environ`: the
    environment its tests would run in now (None: not compared)."""
    if forced:
        return Reason(Dirty.FORCED, "--no-test-cache")
    if key is None:
        return Reason(Dirty.NEW, "not built by wsbuild (no build key), nor all of its test "
                      "closure")
    if last is None:
        return Reason(Dirty.NEW, "no passing result recorded")
    if last.key != key:
        return key.changed_since(last.key) or Reason(Dirty.OPTIONS, "its key changed")
    if last.unobserved:
        return Reason(Dirty.UNOBSERVED,
                      f"its last run was not fully observed ({last.unobserved[0]})")
    if not last.results_kept:
        return Reason(Dirty.RESULTS, "its result files changed or are gone")
    if environ is not None:
        now = variable_digests(environ, last.environment, own_install=own_install,
                               ignored=ignored)
        names = tuple(changed_names(last.environment, now))
        if names:
            return Reason(Dirty.ENVIRONMENT, f"environment variables changed: {' '.join(names)}",
                          details=names)
    changed = first_change(last.reads, Digests())
    if changed is not None:
        return Reason(Dirty.EXTERNAL, f"changed since: {changed}", details=(changed,))
    return None
