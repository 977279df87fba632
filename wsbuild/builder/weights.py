"""The scheduler's weight of each package: its last recorded duration, else an estimate from its
interface and source files (the build type gives the base)."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path

from wsbuild.build_types import get_build_type
from wsbuild.engine.timings import read_durations
from wsbuild.workspace.model import Package

#: estimate (seconds on one core, only relative sizes matter) when no duration is recorded
_ESTIMATE_PER_FILE = {
    ".msg": 4.0, ".srv": 12.0, ".action": 30.0,
    ".c": 1.5, ".cc": 1.5, ".cpp": 1.5, ".cxx": 1.5,
    ".py": 0.02,
}
#: directories an estimate never looks into
_SKIP_DIRS = {"build", "install", "log", "test", "tests", "__pycache__"}

def estimate_seconds(package: Package) -> float:
    """A guess at a package's build time from its interface and source files."""
    total = get_build_type(package.build_type).estimate_base
    for _root, dirs, files in os.walk(package.path):
        dirs[:] = [d for d in dirs if not d.startswith(".") and d not in _SKIP_DIRS]
        for name in files:
            total += _ESTIMATE_PER_FILE.get(os.path.splitext(name)[1], 0.0)
    return total


def package_weights(packages: Mapping[str, Package], names: Iterable[str],
                    build_base: Path) -> dict[str, float]:
    """The scheduler's weight of each package: its last recorded duration, else an estimate."""
    recorded = read_durations(build_base)
    return {name: recorded[name] if name in recorded else estimate_seconds(packages[name])
            for name in names}
