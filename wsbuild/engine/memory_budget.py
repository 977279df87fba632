"""The memory a build may use (its budget), where that figure came from, and how much memory is
free right now (the live guard's reading).

- By default the budget is the limit of the cgroup wsbuild runs in (cgroup v2 `memory.max`,
  v1 `memory.limit_in_bytes`, the smallest along its path: a container, a CI runner, a
  systemd slice), else what the system reports available at the start (`MemAvailable` of
  /proc/meminfo), less a margin: 10 % of the memory the build can see (the cgroup's limit,
  else the machine's), at least 256 MiB and at most 2 GiB.
- `--memory-limit SIZE` (`8G`, `512M`, `1.5GiB`; units are powers of 1024) or `PCT%` (of the
  cgroup's limit, else of the machine's memory) sets it; `--no-memory-limit` turns memory
  admission off.
- Free memory, read every tick of the live guard: in a limited cgroup its limit less what it
  uses (less the page cache the kernel drops first, `inactive_file`), else `MemAvailable`.

Files are read under `proc` and `cgroup` roots so that tests can hand in a tree of their own.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import WsbuildError
from wsbuild.patterns import lazy

KIB = 1024
MIB = KIB * 1024
GIB = MIB * 1024
#: the margin kept free: this share of the memory the build sees, within the bounds below
MARGIN_SHARE = 0.10
MARGIN_MIN = 256 * MIB
MARGIN_MAX = 2 * GIB
#: a cgroup v1 "limit" at or above this is no limit (the kernel writes 2^63 - page size)
_UNLIMITED = 1 << 60
_UNITS = {"": 1, "k": KIB, "m": MIB, "g": GIB, "t": GIB * 1024}
_SIZE = lazy(r"^\s*(\d+(?:\.\d+)?)\s*([kmgt]?)(?:i?b)?\s*$", re.IGNORECASE)
_PERCENT = lazy(r"^\s*(\d+(?:\.\d+)?)\s*%\s*$")

PROC = Path("/proc")
CGROUP = Path("/sys/fs/cgroup")


@dataclass(frozen=True, slots=True)
class MemoryLimit:
    """What the command line (or a defaults file) asked for: the default budget, a size in
    bytes, a share of the memory the build can see, or no budget at all."""

    kind: str = "default"  # "default", "size", "percent", "off"
    value: float = 0.0
    #: as given (`8G`, `50%`), for the words that name where the budget came from
    text: str = ""

    @property
    def off(self) -> bool:
        return self.kind == "off"


def parse_memory_limit(text: str | None, *, off: bool = False) -> MemoryLimit:
    """`--memory-limit TEXT` (None: not given) and `--no-memory-limit` (`off`), checked."""
    if off:
        return MemoryLimit("off")
    if text is None:
        return MemoryLimit()
    percent = _PERCENT.match(text)
    if percent:
        share = float(percent.group(1))
        if not 0 < share <= 100:
            raise WsbuildError(f"--memory-limit {text}: a share must be above 0 % and at most "
                               "100 %", hint="e.g. --memory-limit 50%")
        return MemoryLimit("percent", share, text.strip())
    size = _SIZE.match(text)
    if size is None:
        raise WsbuildError(f"--memory-limit {text!r} is no size",
                           hint="give a size like 8G, 512M, 1.5GiB (powers of 1024), or a "
                                "share of the machine's memory like 50%")
    value = float(size.group(1)) * _UNITS[size.group(2).lower()]
    if value < MIB:
        raise WsbuildError(f"--memory-limit {text}: {int(value)} bytes is too little for any "
                           "build", hint="units are K, M, G, T: e.g. 8G")
    return MemoryLimit("size", value, text.strip())


@dataclass(frozen=True, slots=True)
class MemoryBudget:
    """The budget in bytes, the margin the live guard keeps free, where they came from, and
    how free memory is read during the run (`cgroup`: the limited cgroup's directory)."""

    bytes: int
    margin: int
    source: str
    #: the memory the build can see: the cgroup's limit, else the machine's
    total: int
    cgroup: Path | None = None
    #: cgroup v1 names its files otherwise
    cgroup_v1: bool = False

    def text(self) -> str:
        """`6.9 GiB (what the system had available at the start, 7.9 GiB, less a margin of
        1.0 GiB)`."""
        return f"{format_size(self.bytes)} ({self.source})"

    def as_json(self) -> dict[str, object]:
        return {"bytes": self.bytes, "margin": self.margin, "source": self.source,
                "total": self.total}


def format_size(size: float) -> str:
    """`512 MiB`, `1.4 GiB`: a size as people read it (powers of 1024)."""
    if size >= GIB:
        return f"{size / GIB:.1f} GiB"
    if size >= MIB:
        return f"{size / MIB:.0f} MiB"
    return f"{size / KIB:.0f} KiB"


def margin_of(total: int) -> int:
    return int(min(MARGIN_MAX, max(MARGIN_MIN, total * MARGIN_SHARE)))


def find_budget(limit: MemoryLimit, *, proc: Path = PROC, cgroup: Path = CGROUP
                ) -> MemoryBudget | None:
    """The run's budget as `limit` asks (None: off, or a system that tells nothing)."""
    if limit.off:
        return None
    meminfo = read_meminfo(proc)
    machine = meminfo.get("MemTotal", 0)
    group = cgroup_limit(proc, cgroup)
    limited = group is not None and (not machine or group[0] < machine)
    total = group[0] if group is not None and limited else machine
    if not total:
        return None
    where, v1 = (group[1], group[2]) if group is not None and limited else (None, False)
    margin = margin_of(total)
    seen = (f"the cgroup's limit {format_size(total)}" if where is not None
            else f"the machine's {format_size(total)}")
    if limit.kind == "size":
        return MemoryBudget(int(limit.value), margin, f"--memory-limit {limit.text}", total,
                            where, v1)
    if limit.kind == "percent":
        return MemoryBudget(int(total * limit.value / 100), margin,
                            f"--memory-limit {limit.text} of {seen}", total, where, v1)
    if where is not None:
        return MemoryBudget(max(MIB, total - margin), margin,
                            f"the cgroup's limit {format_size(total)} ({where}) less a margin "
                            f"of {format_size(margin)}", total, where, v1)
    available = meminfo.get("MemAvailable", meminfo.get("MemFree", 0))
    return MemoryBudget(max(MIB, available - margin), margin,
                        f"what the system had available at the start, "
                        f"{format_size(available)}, less a margin of {format_size(margin)}",
                        total)


def read_meminfo(proc: Path = PROC) -> dict[str, int]:
    """/proc/meminfo in bytes (empty where there is none)."""
    found: dict[str, int] = {}
    try:
        text = (proc / "meminfo").read_text()
    except OSError:
        return found
    for line in text.splitlines():
        name, _, value = line.partition(":")
        parts = value.split()
        if parts and parts[0].isdigit():
            found[name.strip()] = int(parts[0]) * (KIB if parts[1:] == ["kB"] else 1)
    return found


def cgroup_limit(proc: Path = PROC, cgroup: Path = CGROUP) -> tuple[int, Path, bool] | None:
    """The smallest memory limit along this process's cgroup path (v2, else v1): the limit,
    the directory that holds it, whether it is v1; None when no cgroup limits memory."""
    try:
        lines = (proc / "self" / "cgroup").read_text().splitlines()
    except OSError:
        return None
    for line in lines:
        number, _, rest = line.partition(":")
        controllers, _, path = rest.partition(":")
        if number == "0" and controllers == "":
            found = _smallest(cgroup, path, "memory.max")
            if found is not None:
                return (*found, False)
    for line in lines:
        _, _, rest = line.partition(":")
        controllers, _, path = rest.partition(":")
        if "memory" in controllers.split(","):
            found = _smallest(cgroup / "memory", path, "memory.limit_in_bytes")
            if found is not None:
                return (*found, True)
    return None


def _smallest(root: Path, path: str, name: str) -> tuple[int, Path] | None:
    """The smallest limit in `name` from `root/path` up to `root` (a container sees its own
    cgroup as the root: then `root` itself holds it)."""
    best: tuple[int, Path] | None = None
    parts = [p for p in path.strip("/").split("/") if p]
    for depth in range(len(parts), -1, -1):
        directory = root.joinpath(*parts[:depth])
        try:
            text = (directory / name).read_text().strip()
        except OSError:
            continue
        if not text.isdigit() or int(text) >= _UNLIMITED:
            continue  # "max", or v1's "unlimited"
        if best is None or int(text) < best[0]:
            best = (int(text), directory)
    return best


def free_memory(budget: MemoryBudget, proc: Path = PROC) -> int | None:
    """The memory free for the build now: in the limited cgroup, its limit less what it uses
    (the inactive page cache, which the kernel drops first, counted as free); else what the
    system reports available. None when it cannot be read."""
    if budget.cgroup is not None:
        usage_file = "memory.usage_in_bytes" if budget.cgroup_v1 else "memory.current"
        try:
            usage = int((budget.cgroup / usage_file).read_text().strip())
        except (OSError, ValueError):
            return None
        inactive = _stat_value(budget.cgroup / "memory.stat",
                               "total_inactive_file" if budget.cgroup_v1 else "inactive_file")
        return budget.total - max(0, usage - inactive)
    meminfo = read_meminfo(proc)
    return meminfo.get("MemAvailable")


def _stat_value(path: Path, name: str) -> int:
    try:
        for line in path.read_text().splitlines():
            key, _, value = line.partition(" ")
            if key == name:
                return int(value)
    except (OSError, ValueError):
        pass
    return 0


def page_size() -> int:
    try:
        return os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return 4096
