"""The resident memory of a build's process tree at one moment: the whole tree's, each
package's (the processes its steps started), and each job under a make or Ninja of a package.

A *job* is what a jobserver token (or a make's or Ninja's own implicit slot) starts: a process
whose parent is a make or Ninja and which is none itself (a compile through its launcher, a
link, a code generator), with everything under it. The tree is walked from the root through
`/proc/<pid>/task/<tid>/children` and each process read once from `/proc/<pid>/stat` (its
name, parent and resident pages): a few dozen small reads per snapshot. Resident memory is
summed per process (RSS: shared pages count in each process that maps them, so the sum can
only overstate what the processes need). Elsewhere than Linux a snapshot is empty.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field

from wsbuild.engine.memory_budget import page_size

#: the programs that hand out jobs: their children are jobs (cmake --build only runs one)
DRIVERS = frozenset({"make", "gmake", "ninja", "samu"})
_PAGE = page_size()


@dataclass(frozen=True, slots=True)
class PackageMemory:
    """One package's processes at one moment."""

    rss: int
    #: the resident memory of each job (by the pid of its first process)
    jobs: Mapping[int, int] = field(default_factory=dict)
    #: a make or Ninja runs among them (so its jobs may take jobserver tokens)
    driving: bool = False


@dataclass(frozen=True, slots=True)
class TreeSnapshot:
    """The tree's resident memory (the root's own included), and that of each package."""

    total: int
    packages: Mapping[str, PackageMemory] = field(default_factory=dict)


@dataclass(slots=True)
class _Process:
    """One process of the build's tree, as /proc shows it."""

    ppid: int
    name: str
    rss: int
    children: list[int] = field(default_factory=list)


def _read_stat(pid: int) -> _Process | None:
    try:
        with open(f"/proc/{pid}/stat", "rb") as handle:
            text = handle.read()
    except OSError:
        return None
    # "pid (comm) state ppid ... rss(24th)": the name may hold spaces and parentheses
    head, _, rest = text.rpartition(b")")
    fields = rest.split()
    try:
        return _Process(int(fields[1]), head.partition(b"(")[2].decode(errors="replace"),
                        int(fields[21]) * _PAGE)
    except (IndexError, ValueError):
        return None


def _children(pid: int) -> list[int]:
    found: list[int] = []
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return found
    for tid in tasks:
        try:
            with open(f"/proc/{pid}/task/{tid}/children", "rb") as handle:
                found += [int(c) for c in handle.read().split()]
        except (OSError, ValueError):
            continue
    return found


def read_tree(root: int) -> dict[int, _Process]:
    """Every live process under `root`, `root` included (empty when /proc cannot tell)."""
    tree: dict[int, _Process] = {}
    stack = [root]
    while stack:
        pid = stack.pop()
        if pid in tree:
            continue
        process = _read_stat(pid)
        if process is None:
            continue
        process.children = _children(pid)
        tree[pid] = process
        stack += process.children
    return tree


def snapshot(root: int, owners: Mapping[int, str]) -> TreeSnapshot:
    """The tree under `root` now; `owners`: the first process of each step → its package."""
    return measure(read_tree(root), owners)


def measure(tree: Mapping[int, _Process], owners: Mapping[int, str]) -> TreeSnapshot:
    """What `tree` (read_tree's) holds, by package and job."""
    sizes: dict[int, int] = {}

    def size(pid: int) -> int:
        if pid not in sizes:
            process = tree[pid]
            sizes[pid] = process.rss + sum(size(c) for c in process.children if c in tree)
        return sizes[pid]

    total = sum(p.rss for p in tree.values())
    packages: dict[str, PackageMemory] = {}
    for leader, package in owners.items():
        if leader not in tree:
            continue
        jobs: dict[int, int] = {}
        driving = False
        stack = [leader]
        while stack:
            pid = stack.pop()
            process = tree[pid]
            is_driver = process.name in DRIVERS
            driving = driving or is_driver
            for child in process.children:
                if child not in tree:
                    continue
                if is_driver and tree[child].name not in DRIVERS:
                    jobs[child] = size(child)
                else:
                    stack.append(child)
        earlier = packages.get(package)
        if earlier is not None:  # two steps of one package at once (a helper): one package
            jobs = {**earlier.jobs, **jobs}
            driving = driving or earlier.driving
        packages[package] = PackageMemory(size(leader) + (earlier.rss if earlier else 0),
                                          jobs, driving)
    return TreeSnapshot(total, packages)
