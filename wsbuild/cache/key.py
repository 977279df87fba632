"""The cache key: a package's inputs key plus the machine it is for.

The inputs key (record/model.py) covers the sources, the options, the interpreter, the
underlay's paths, the dependencies' inputs keys and the absolute install prefix: what is
known before a build reads anything. What the build's steps read (outside files, system
headers and libraries, the compilers and tools they ran, the environment variables) is not
known before it runs, so an entry carries its package record and is restored only when this
machine proves it, file by file and variable by variable (cache/run.py). The key adds only
the platform (OS release, machine, C library) and wsbuild's version; nothing machine-wide
that no step read (the installed Debian packages, the toolchain as a whole) keeps two
machines from sharing an entry.

An entry is found under its key and under a variant of it: the key with the digests of the
variables its steps read (`variant`). Two users whose builds read HOME each find their own
entry under the variant their HOME gives, and a build that read no variable that differs
between them is one entry for both.

A second checkout at another path misses: installed files embed the absolute prefix (CMake
config files, setup scripts, shebangs), so relocating them would mean rewriting binaries.
"""

from __future__ import annotations

import functools
import hashlib
import json
import platform
import sys
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from wsbuild.patterns import lazy


#: bumped whenever the entry layout changes; old entries then simply miss
ENTRY_FORMAT = 3
_HEX64 = lazy(r"[0-9a-f]{64}")
_FIRST_CALL = threading.Lock()


def is_digest(text: str) -> bool:
    """A sha256 as the cache layout spells it: 64 lowercase hex digits, nothing else."""
    return _HEX64.fullmatch(text) is not None


@dataclass(frozen=True, slots=True)
class CacheKey:
    """The key of a package's cache entry, and what it was made of."""

    package: str
    #: what the key is made of (canonical JSON), kept for logs and debugging
    text: str
    #: a digest of the values of the variables an entry's steps read ("": the key itself)
    variant: str = ""

    @property
    def address(self) -> str:
        """The action-cache address: sha256 of the key text (and of the variant)."""
        text = f"{self.text}\0{self.variant}" if self.variant else self.text
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def addresses(self) -> tuple[str, ...]:
        """Where an entry stored under this key is found: the key's own address, and the
        variant's."""
        plain = hashlib.sha256(self.text.encode()).hexdigest()
        return (plain, self.address) if self.variant else (plain,)

    @property
    def variants_address(self) -> str:
        """Where the list of the variable names of this key's variants is kept."""
        return hashlib.sha256(f"{self.text}\0variants".encode()).hexdigest()

    def with_variant(self, environment: Mapping[str, str]) -> CacheKey:
        """This key's variant for the digests of the variables a build read."""
        text = json.dumps(sorted(environment.items()), separators=(",", ":"))
        return CacheKey(self.package, self.text, hashlib.sha256(text.encode()).hexdigest())


def cache_key(*, package: str, inputs_key: str, build_type: str, version: str) -> CacheKey:
    """The key under which `package`'s install is stored. The install prefix is not a part
    of its own: the inputs key holds it (builder/plan.py `package_settings`)."""
    with _FIRST_CALL:  # the first call looks at the machine; the others wait and reuse it
        platform = platform_id()
    parts = {
        "format": ENTRY_FORMAT,
        "package": package,
        "build_type": build_type,
        "inputs_key": inputs_key,
        "wsbuild": version,
        "platform": platform,
    }
    return CacheKey(package, json.dumps(parts, sort_keys=True, separators=(",", ":")))


@functools.lru_cache(maxsize=1)
def platform_id() -> str:
    """OS release, machine and C library: binaries built on one seldom run on another."""
    release = ""
    try:
        fields = dict(
            line.split("=", 1) for line in Path("/etc/os-release").read_text().splitlines()
            if "=" in line
        )
        release = f"{fields.get('ID', '').strip(chr(34))} {fields.get('VERSION_ID', '').strip(chr(34))}"
    except OSError:
        pass
    libc = " ".join(platform.libc_ver())
    return f"{sys.platform} {platform.machine()} {release.strip()} {libc}".strip()


#: the most variants (sets of variables read) a key's list keeps, most recent first
MAX_VARIANTS = 16


def variant_list(data: bytes | None) -> list[tuple[str, ...]]:
    """A key's variants document (at its `variants_address`): a JSON list of lists of
    variable names; [] when it is not one."""
    found = parse_variants(data)
    return found if found is not None else []


def parse_variants(data: bytes | None) -> list[tuple[str, ...]] | None:
    """The variants document `data` holds, None when it is not one."""
    try:
        value = json.loads(data) if data else None
    except ValueError:
        return None
    if not isinstance(value, list) or not all(
            isinstance(names, list) and all(isinstance(n, str) for n in names)
            for names in value):
        return None
    return [tuple(names) for names in value[:MAX_VARIANTS]]


def with_variant(known: list[tuple[str, ...]], names: tuple[str, ...]) -> bytes:
    """The variants document with `names` first."""
    merged = [names, *(n for n in known if n != names)][:MAX_VARIANTS]
    return json.dumps([list(n) for n in merged]).encode()
