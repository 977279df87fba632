"""The cache key: a package's build key plus everything else that changes its installed bytes.

The build key (build/fingerprint.py) already covers the sources, the options, the interpreter,
the underlay's paths, the dependencies' keys and the absolute install prefix. Across machines
that is not enough, so the cache key adds the platform (OS release, machine, C library), the
toolchain (compilers and CMake, by version) and the underlay's contents (installed Python
distributions and ROS package versions), each identified once per run.

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
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

#: bumped whenever the entry layout changes; old entries then simply miss
ENTRY_FORMAT = 1
_HEX64 = re.compile(r"[0-9a-f]{64}")


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


def cache_key(*, package: str, build_key: str, install_prefix: Path, build_type: str,
              environ: Mapping[str, str], version: str,
              workspace_install: Path | None = None) -> CacheKey:
    """The key under which `package`'s install is stored. `environ` is the build environment
    (its compilers and underlay count); prefixes below `workspace_install` are not underlay."""
    parts = {
        "format": ENTRY_FORMAT,
        "package": package,
        "build_type": build_type,
        "build_key": build_key,
        "install_prefix": str(install_prefix),
        "wsbuild": version,
        "platform": platform_id(),
        "toolchain": toolchain_id(environ.get("CC", ""), environ.get("CXX", ""),
                                  environ.get("PATH", os.defpath)),
        "underlay": underlay_id(environ.get("AMENT_PREFIX_PATH", ""),
                                str(workspace_install) if workspace_install else ""),
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


def _first_line(command: list[str]) -> str:
    try:
        completed = subprocess.run(command, capture_output=True, text=True, timeout=10,
                                   stdin=subprocess.DEVNULL)
    except (OSError, subprocess.SubprocessError):
        return "unavailable"
    lines = (completed.stdout or completed.stderr).splitlines()
    return lines[0].strip() if lines else "unavailable"


@functools.lru_cache(maxsize=8)
def toolchain_id(cc: str, cxx: str, path: str) -> str:
    """The C and C++ compilers CMake would pick and CMake itself, by resolved path and version."""
    found = []
    for tool in (cc or "cc", cxx or "c++", "cmake"):
        program = tool.split()[0] if tool.strip() else tool
        located = shutil.which(program, path=path)
        if located is None:
            found.append(f"{program}: none")
            continue
        found.append(f"{os.path.realpath(located)}: {_first_line([located, '--version'])}")
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
