"""The cache key: a package's inputs key plus everything else that changes its installed bytes.

The inputs key (record/model.py) already covers the sources, the options, the interpreter,
the underlay's paths, the environment (but the variables that differ between machines and
users), the dependencies' inputs keys and the absolute install prefix; what the build read
outside the package is not known before it runs, so an entry carries its package record and
is restored only when this machine proves it (cache/run.py). Across machines that is not
enough, so the cache key adds the platform (OS release, machine, C library), the
toolchain (compilers and CMake, by version), the underlay's contents (installed Python
distributions and ROS package versions) and the system's packages (every installed Debian
package with its version: the headers, libraries and CMake modules a build reads from /usr
come from them, so a machine with another `libfoo-dev` point release never restores this
machine's build), each identified once per run. Files outside any package manager's
control (a hand-made /usr/local or /opt tree) are not in the key: what a build read of them is
in its record, which a restore proves file by file.

A second checkout at another path misses: installed files embed the absolute prefix (CMake
config files, setup scripts, shebangs), so relocating them would mean rewriting binaries.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import sysconfig
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from wsbuild.files import atomic_write

#: bumped whenever the entry layout changes; old entries then simply miss
ENTRY_FORMAT = 2
_HEX64 = re.compile(r"[0-9a-f]{64}")
_FIRST_CALL = threading.Lock()


def is_digest(text: str) -> bool:
    """A sha256 as the cache layout spells it: 64 lowercase hex digits, nothing else."""
    return _HEX64.fullmatch(text) is not None


@dataclass(frozen=True, slots=True)
class CacheKey:
    package: str
    #: what the key is made of (canonical JSON), kept for logs and debugging
    text: str

    @property
    def address(self) -> str:
        """The action-cache address: sha256 of the key text."""
        return hashlib.sha256(self.text.encode()).hexdigest()


def cache_key(*, package: str, inputs_key: str, install_prefix: Path, build_type: str,
              environ: Mapping[str, str], version: str,
              workspace_install: Path | None = None, memo: Path | None = None) -> CacheKey:
    """The key under which `package`'s install is stored. `environ` is the build environment
    (its compilers and underlay count); prefixes below `workspace_install` are not underlay;
    `memo` remembers compiler versions between runs (see toolchain_id)."""
    with _FIRST_CALL:  # the first call measures the machine; the others wait and reuse it
        platform = platform_id()
        toolchain = toolchain_id(environ.get("CC", ""), environ.get("CXX", ""),
                                 environ.get("PATH", os.defpath), memo)
        underlay = underlay_id(environ.get("AMENT_PREFIX_PATH", ""),
                               str(workspace_install) if workspace_install else "")
        system = system_packages_id()
    parts = {
        "format": ENTRY_FORMAT,
        "package": package,
        "build_type": build_type,
        "inputs_key": inputs_key,
        "install_prefix": str(install_prefix),
        "wsbuild": version,
        "platform": platform,
        "toolchain": toolchain,
        "underlay": underlay,
        "system": system,
    }
    return CacheKey(package, json.dumps(parts, sort_keys=True, separators=(",", ":")))


#: dpkg's database of installed packages
DPKG_STATUS = Path("/var/lib/dpkg/status")


@functools.lru_cache(maxsize=1)
def system_packages_id() -> str:
    """Digest of the installed Debian packages and their versions ("" without dpkg)."""
    try:
        text = DPKG_STATUS.read_text(errors="replace")
    except OSError:
        return ""
    digest = hashlib.sha256()
    for stanza in text.split("\n\n"):
        fields = dict(line.split(": ", 1) for line in stanza.splitlines()
                      if ": " in line and not line.startswith(" "))
        if fields.get("Status", "").endswith(" installed"):
            digest.update(f"{fields.get('Package')} {fields.get('Architecture')} "
                          f"{fields.get('Version')}\n".encode())
    return digest.hexdigest()


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


def _version_lines(programs: list[str]) -> dict[str, str]:
    """First line of `program --version` for each program, the calls running at once."""
    running = []
    for program in programs:
        try:
            running.append((program, subprocess.Popen(
                [program, "--version"], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT, text=True)))
        except OSError:
            continue
    lines: dict[str, str] = {}
    for program, process in running:
        try:
            out, _ = process.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            out, _ = process.communicate()
        first = out.splitlines()
        lines[program] = first[0].strip() if first else "unavailable"
    return lines


@functools.lru_cache(maxsize=8)
def toolchain_id(cc: str, cxx: str, path: str, memo: Path | None = None) -> str:
    """The C and C++ compilers CMake would pick and CMake itself, by resolved path and version.

    `memo` (a JSON file) remembers each program's version line by its path, size and mtime,
    so later runs need three stats instead of three processes."""
    programs: dict[str, str | None] = {}
    for tool in (cc or "cc", cxx or "c++", "cmake"):
        program = tool.split()[0] if tool.strip() else tool
        located = shutil.which(program, path=path)
        programs[program] = os.path.realpath(located) if located else None
    known: dict[str, list[object]] = {}
    if memo is not None:
        try:
            known = json.loads(memo.read_text())
        except (OSError, ValueError):
            known = {}
    stamps: dict[str, list[object]] = {}
    for real in filter(None, programs.values()):
        try:
            info = os.stat(real)
            stamps[real] = [info.st_size, info.st_mtime_ns]
        except OSError:
            stamps[real] = [0, 0]
    missing = [real for real in stamps
               if not (isinstance(known.get(real), list) and known[real][:2] == stamps[real])]
    if missing:
        for real, line in _version_lines(missing).items():
            known[real] = [*stamps[real], line]
        if memo is not None:
            try:
                memo.parent.mkdir(parents=True, exist_ok=True)
                atomic_write(memo, json.dumps(known, sort_keys=True))
            except OSError:
                pass
    found = []
    for program, real in programs.items():
        entry = known.get(real) if real else None
        line = entry[2] if isinstance(entry, list) and len(entry) > 2 else "unavailable"
        found.append(f"{real}: {line}" if real else f"{program}: none")
    return "; ".join(found)


_VERSION_TAG = re.compile(rb"<version[^>]*>\s*([^<\s]+)\s*</version>")


@functools.lru_cache(maxsize=8)
def underlay_id(ament_prefix_path: str, own_install: str) -> str:
    """Digest of what the build links and imports from outside the workspace: the
    interpreter's installed distributions (names carry versions) and, for every underlay
    prefix, its ROS packages with their package.xml versions."""
    digest = hashlib.sha256()
    paths = sysconfig.get_paths()
    for lib in sorted({paths["purelib"], paths["platlib"]}):
        try:
            names = sorted(n for n in os.listdir(lib)
                           if n.endswith((".dist-info", ".egg-info")) and not n.startswith("wsbuild"))
        except OSError:
            names = []
        digest.update(f"{lib}\n".encode() + "\n".join(names).encode() + b"\n")
    for prefix in ament_prefix_path.split(os.pathsep):
        if not prefix or (own_install and prefix.startswith(own_install)):
            continue
        index = Path(prefix, "share", "ament_index", "resource_index", "packages")
        try:
            packages = sorted(os.listdir(index))
        except OSError:
            continue
        digest.update(f"{prefix}\n".encode())
        for name in packages:
            try:
                match = _VERSION_TAG.search(Path(prefix, "share", name, "package.xml").read_bytes())
            except OSError:
                match = None
            version = match.group(1).decode(errors="replace") if match else "?"
            digest.update(f"{name} {version}\n".encode())
    return digest.hexdigest()
