"""The build cache as one run uses it: opened when the first package needs building (a no-op
build never pays for it), a package's cache key from its inputs key, lookups while the run is
planned, and restores committed into install/ exactly as a build commits its stage.

An entry carries the package record it was built with (record/model.py), and is restored only
when this machine proves it (ccache's direct mode, BuildXL's observed path sets): the record's
inputs key is the one looked up, its steps were all observed and its build system had no work
left, each dependency's key here is the one it was built against (those built in this run
once they are), every variable its steps read has the same value here, and every file,
listing, search and probe it read outside the package has the same content here. An entry
whose variables differ here is looked for once more under the variant of its key those
variables' values here give (cache/key.py): a build that read HOME is found for this HOME
only. After a restore the package's record is the entry's, with this machine's signatures,
so later edits are seen."""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild import __version__
from wsbuild.cache.settings import CacheSettings
from wsbuild.events import Emit, Notice
from wsbuild.record.model import decode, encode
from wsbuild.redaction import redact
from wsbuild.words import plural
from wsbuild.workspace.root import Workspace

if TYPE_CHECKING:
    from wsbuild.cache.client import BuildCache, Found, Restored
    from wsbuild.cache.key import CacheKey
    from wsbuild.record.dirty import Environment
    from wsbuild.record.model import PackageRecord
    from wsbuild.record.outside import Digests



#: why the proof refuses an entry that no wsbuild could use (not one that another machine's
#: files or dependencies disprove): a server answering with these is named once per run
NO_RECORD = "the entry carries no package record"
UNREADABLE_RECORD = "the entry's package record cannot be read"
OTHER_INPUTS = "the entry's package record is not of these inputs"
UNUSABLE = frozenset({NO_RECORD, UNREADABLE_RECORD, OTHER_INPUTS})


@dataclass(frozen=True, slots=True)
class Proven:
    """An entry this machine proved while the run was planned, its package record and the
    key (or variant of it) it was found under."""

    found: Found
    record: PackageRecord
    key: CacheKey | None = None


@dataclass(frozen=True, slots=True)
class Disproof:
    """Why an entry is not restored here, and its record when it could be read."""

    why: str
    record: PackageRecord | None = None
    #: the variables its steps read differ here (its key's variant may hold another entry)
    variables: bool = False


def disproof(found: Found, inputs_key: str, dependencies: Mapping[str, str], digests: Digests,
             *, install_base: Path, planning: bool, waiting: bool = False,
             environment: Environment | None = None) -> PackageRecord | Disproof:
    """The entry's package record when this machine proves it, else why not (`Disproof`).
    `dependencies`: the keys the package's dependencies have here (a PENDING one is not
    compared: its build in this run decides, and the restore asks again); `waiting`: some
    dependency is yet to be built or restored in this run, so what the entry read in the
    install base is compared at the restore only; `environment`: the variables here."""
    from wsbuild.record.dirty import Dirty, changed_read  # lazy: off `info`

    if found.package_record is None:
        return Disproof(NO_RECORD)
    try:
        import json

        record = decode(json.loads(found.package_record))
    except ValueError:
        record = None
    if record is None:
        return Disproof(UNREADABLE_RECORD)
    if record.inputs_key != inputs_key:
        return Disproof(OTHER_INPUTS)
    changed = changed_read(record, digests=digests, install_base=install_base,
                           planning=planning, dependencies=dependencies, waiting=waiting,
                           environment=environment)
    if changed is not None:
        return Disproof(changed.text, record, changed.kind is Dirty.ENVIRONMENT)
    return record


@dataclass(frozen=True, slots=True)
class Refused:
    """An entry found and not proved here, and why."""

    why: str
    found: Found


class RunCache:
    """One run's cache. Thread-safe: packages build in worker threads."""

    def __init__(self, settings: CacheSettings | None, workspace: Workspace, emit: Emit, *,
                 symlink_install: bool, log: Path | None = None) -> None:
        # a symlink install points into src/ and build/: nothing a cache could carry
        self.settings = None if symlink_install else settings
        self.workspace = workspace
        self._emit = emit
        self._lock = threading.Lock()
        self._cache: BuildCache | None = None
        #: where close() writes what the cache cost and did (the run's log directory)
        self._log = log
        self._seconds = {"lookup": 0.0, "restore": 0.0, "store": 0.0}
        self._counts = {"lookup": 0, "restore": 0, "store": 0}
        self._misses: list[str] = []
        #: the variables here (the session's, set when the session opens; None: not compared)
        self.environment: Environment | None = None
        #: the packages whose entry on the server no wsbuild could use (`UNUSABLE`)
        self._unusable: set[str] = set()

    def _account(self, what: str, started: float) -> None:
        with self._lock:
            self._seconds[what] += time.perf_counter() - started
            self._counts[what] += 1

    @property
    def enabled(self) -> bool:
        return self.settings is not None

    def _open(self) -> BuildCache:
        with self._lock:
            if self._cache is None:
                from wsbuild.cache.client import BuildCache  # lazy: off the full no-op build

                assert self.settings is not None
                self._cache = BuildCache.open(self.settings, warn=self._warn)
            assert self._cache is not None
            return self._cache

    def _warn(self, text: str) -> None:
        self._emit(Notice(text, warning=True))

    def _refused(self, key: CacheKey, found: Found, why_not: str) -> None:
        """Note a refused entry: in the run's log, and counted when it came from the server
        and no wsbuild could use it."""
        with self._lock:
            self._misses.append(f"{key.package}: {why_not}")
            if why_not in UNUSABLE and not found.from_local:
                self._unusable.add(key.package)

    def _name_unusable_server(self) -> None:
        """One warning naming a server that answered with entries no wsbuild could use."""
        if not self._unusable or self.settings is None:
            return

        count = len(self._unusable)
        self._warn(f"cache server {redact(self.settings.url or '')} answered "
                   f"{plural(count, 'entry', 'entries')} wsbuild cannot use (no package record "
                   "of these inputs: not a wsbuild cache, or it serves something else at "
                   f"these addresses); {'it was' if count == 1 else 'they were'} refused "
                   "before anything was unpacked, and built here")

    def key(self, name: str, build_type: str, inputs_key: str) -> CacheKey | None:
        if self.settings is None:
            return None
        started = time.perf_counter()
        from wsbuild.cache.key import cache_key  # lazy: off the full no-op build and `info`

        key = cache_key(package=name, inputs_key=inputs_key, build_type=build_type,
                        version=__version__)
        with self._lock:  # counted with the lookups
            self._seconds["lookup"] += time.perf_counter() - started
        return key

    def _proven(self, key: CacheKey, inputs_key: str, dependencies: Mapping[str, str],
                digests: Digests, *, planning: bool, waiting: bool = False
                ) -> Proven | Refused | None:
        """The entry under `key`, or under the variant of it the variables here give, when
        this machine proves it; None when there is none; else why it is not restored."""
        cache = self._open()
        found = cache.find(key)
        if found is None:
            return None
        proof = disproof(found, inputs_key, dependencies, digests,
                         install_base=self.workspace.install_base, planning=planning,
                         waiting=waiting, environment=self.environment)
        if not isinstance(proof, Disproof):
            return Proven(found, proof, key)
        if not proof.variables or proof.record is None or self.environment is None:
            return Refused(proof.why, found)
        first, first_found = proof.why, found
        tried: set[str] = {key.address}
        for names in [tuple(sorted(proof.record.environment)), *cache.variants(key)]:
            variant = key.with_variant(self.environment.digests(names))
            if variant.address in tried:
                continue
            tried.add(variant.address)
            found = cache.find(variant)
            if found is None:
                continue
            proof = disproof(found, inputs_key, dependencies, digests,
                             install_base=self.workspace.install_base, planning=planning,
                             waiting=waiting, environment=self.environment)
            if not isinstance(proof, Disproof):
                return Proven(found, proof, variant)
        return Refused(f"{first}, and no entry was built where they are as here", first_found)

    def lookup(self, key: CacheKey, inputs_key: str, dependencies: Mapping[str, str],
               digests: Digests, *, waiting: bool = False) -> Proven | None:
        """The cache's entry for `key` (locally or on the server) when this machine proves it
        (`disproof`; `waiting`: a dependency is yet to be built or restored in this run),
        None otherwise; reads only."""
        started = time.perf_counter()
        proven = self._proven(key, inputs_key, dependencies, digests, planning=True,
                              waiting=waiting)
        if not isinstance(proven, Proven):
            self._account("lookup", started)
            if proven is None:
                with self._lock:  # for "why was this not restored?": in the log
                    self._misses.append(f"{key.package}: not in the cache under "
                                        f"{key.address} = sha256 of {key.text}")
            else:
                self._refused(key, proven.found, proven.why)
            return None
        with self._lock:  # counted with the restore that follows
            self._seconds["restore"] += time.perf_counter() - started
        return proven

    def probe(self, key: CacheKey, inputs_key: str, dependencies: Mapping[str, str],
              digests: Digests) -> Proven | str | None:
        """The entry for `key` when it is there and this machine proves it; None when it is
        not there (yet) and the cache can still be asked; else why it will not be restored
        (another build's entry, the server off for this run). Unlike `lookup` nothing goes
        into the run's log: cache/waiting.py asks again and again while another job of a CI
        matrix builds the package."""
        cache = self._open()
        proven = self._proven(key, inputs_key, dependencies, digests, planning=False)
        if proven is None:
            off = self.settings is not None and self.settings.url and cache.remote is None
            return "the cache server is off for this run" if off else None
        return proven.why if isinstance(proven, Refused) else proven

    def restore(self, key: CacheKey, found: Found, prefix: Path, merged_record: Path | None, *,
                inputs_key: str, dependencies: Mapping[str, str], digests: Digests
                ) -> tuple[Restored, PackageRecord, list[tuple[str, int]]] | str:
        """Unpack the entry `lookup` found into a fresh stage and commit it to `prefix` as a
        build would (`merged_record`: the package's file list in a merged install), once this
        machine proves it again with its dependencies' keys as this run left them; the entry's
        package record and the installed files. Else why it was refused (the package is then
        built)."""
        from wsbuild.prefix import stage as staging  # lazy: off `info` and `build --dry-run`

        started = time.perf_counter()
        entry_record = disproof(found, inputs_key, dependencies, digests,
                                install_base=self.workspace.install_base, planning=False,
                                environment=self.environment)
        if isinstance(entry_record, Disproof):
            self._account("lookup", started)
            self._refused(key, found, entry_record.why)
            return entry_record.why
        cache = self._open()
        install_base = self.workspace.install_base
        stage = staging.new_stage(install_base, key.package)
        try:
            restored = cache.restore(key, stage, found)
            if restored is None:
                staging.discard_stage(stage)
                self._account("lookup", started)
                return "the entry's archive could not be had"
            if merged_record is not None:
                staging.commit_merged(stage, prefix, merged_record)
                files = merged_record.read_text().splitlines()
                result = (restored, entry_record,
                          staging.installed_files(install_base, prefix, files))
            else:
                staging.commit_isolated(stage, prefix)
                result = restored, entry_record, staging.installed_files(install_base, prefix)
        except BaseException:
            staging.discard_stage(stage)
            raise
        self._account("restore", started)
        return result

    def store(self, key: CacheKey, prefix: Path, merged_record: Path | None,
              package_record: PackageRecord) -> str | None:
        """Store the package just installed at `prefix` with the record it was built with;
        None when stored (or queued), else why not. An isolated prefix is packed on the cache's
        thread while the build goes on: only a rebuild of the same package would change it,
        and that cannot happen in this run. A merged prefix is shared, so it is packed at
        once."""
        import json

        if not package_record.complete or package_record.volatile:
            return ("not cached: its steps were not all observed" if not package_record.complete
                    else "not cached: its build system always has work")
        started = time.perf_counter()
        files = merged_record.read_text().splitlines() if merged_record is not None else None
        key = key.with_variant(package_record.environment)
        data = json.dumps(encode(package_record), separators=(",", ":")).encode()
        why_not = self._open().store(key, prefix, files, package_record=data,
                                     background=merged_record is None,
                                     variables=tuple(sorted(package_record.environment)))
        self._account("store", started)
        return why_not

    def close(self, *, wait: bool = True) -> None:
        """Finish uploads and evict old local entries (wait=False after Ctrl-C); write what
        the cache cost into the run's log."""
        if self._cache is None:
            return
        self._name_unusable_server()
        started = time.perf_counter()
        closing_cache, self._cache = self._cache, None
        closing_cache.close(wait=wait)
        closing = time.perf_counter() - started
        if self._log is not None:
            s, n = self._seconds, self._counts
            text = (f"build cache: {n['lookup']} missed ({s['lookup']:.3f} s), "
                    f"{n['restore']} restored ({s['restore']:.3f} s), "
                    f"{n['store']} stored ({s['store']:.3f} s), "
                    f"closing (uploads, eviction) {closing:.3f} s; "
                    f"on the cache's thread meanwhile: {closing_cache.background_seconds:.3f} s, "
                    f"of which CPU {closing_cache.background_cpu_seconds:.3f} s\n")
            text += "".join(f"build cache: {note}\n" for note in closing_cache.notes)
            text += "".join(f"build cache: {miss}\n" for miss in sorted(self._misses))
            try:
                with open(self._log, "a") as handle:
                    handle.write(text)
            except OSError:
                pass
