"""engine/memory_budget.py: `--memory-limit`, and the default budget from the cgroup's limit
or what the system has available, read from /proc and /sys/fs/cgroup trees the tests write
(the machine's own cgroup is not the tests' to change)."""

from __future__ import annotations

from pathlib import Path

import pytest

from wsbuild.engine.memory_budget import (
    GIB,
    MIB,
    MemoryLimit,
    find_budget,
    free_memory,
    parse_memory_limit,
)
from wsbuild.errors import WsbuildError


def _system(tmp_path: Path, *, total_kib: int = 16 * 1024 * 1024,
            available_kib: int = 10 * 1024 * 1024, cgroup: str = "0::/user.slice/job\n",
            files: dict[str, str] | None = None) -> tuple[Path, Path]:
    proc, sys_cgroup = tmp_path / "proc", tmp_path / "cgroup"
    (proc / "self").mkdir(parents=True)
    (proc / "meminfo").write_text(f"MemTotal:       {total_kib} kB\nMemFree:        1 kB\n"
                                  f"MemAvailable:   {available_kib} kB\n")
    (proc / "self" / "cgroup").write_text(cgroup)
    for name, text in (files or {}).items():
        path = sys_cgroup / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return proc, sys_cgroup


@pytest.mark.parametrize(("text", "expected"), [
    ("8G", MemoryLimit("size", 8 * GIB, "8G")), ("512M", MemoryLimit("size", 512 * MIB, "512M")),
    ("1.5GiB", MemoryLimit("size", 1.5 * GIB, "1.5GiB")),
    ("2048mb", MemoryLimit("size", 2 * GIB, "2048mb")), ("50%", MemoryLimit("percent", 50, "50%")),
    (None, MemoryLimit()),
])
def test_a_limit_is_a_size_in_powers_of_1024_or_a_share(text: str | None,
                                                          expected: MemoryLimit) -> None:
    assert parse_memory_limit(text) == expected


@pytest.mark.parametrize("text", ["8X", "lots", "0%", "150%", "100"])
def test_a_limit_that_is_no_size_names_what_would_be(text: str) -> None:
    with pytest.raises(WsbuildError) as caught:
        parse_memory_limit(text)
    assert "--memory-limit" in str(caught.value)
    assert caught.value.hint


def test_no_memory_limit_turns_the_budget_off(tmp_path: Path) -> None:
    proc, cgroup = _system(tmp_path)
    assert parse_memory_limit("8G", off=True).off
    assert find_budget(parse_memory_limit(None, off=True), proc=proc, cgroup=cgroup) is None


def test_without_a_cgroup_limit_the_budget_is_what_is_available_less_the_margin(
        tmp_path: Path) -> None:
    proc, cgroup = _system(tmp_path, files={"user.slice/job/memory.max": "max\n"})
    budget = find_budget(MemoryLimit(), proc=proc, cgroup=cgroup)
    assert budget is not None
    # the margin: 10 % of the machine's 16 GiB, at most 2 GiB
    assert budget.margin == int(1.6 * GIB)
    assert budget.bytes == 10 * GIB - budget.margin
    assert budget.cgroup is None
    assert "available at the start, 10.0 GiB, less a margin of 1.6 GiB" in budget.source


def test_the_smallest_cgroup_v2_limit_along_the_path_is_the_budget(tmp_path: Path) -> None:
    proc, cgroup = _system(tmp_path, files={"user.slice/job/memory.max": "max\n",
                                            "user.slice/memory.max": f"{4 * GIB}\n",
                                            "memory.max": f"{8 * GIB}\n"})
    budget = find_budget(MemoryLimit(), proc=proc, cgroup=cgroup)
    assert budget is not None and budget.cgroup == cgroup / "user.slice"
    assert budget.total == 4 * GIB
    assert budget.margin == int(0.4 * GIB)
    assert budget.bytes == 4 * GIB - budget.margin
    assert "the cgroup's limit 4.0 GiB" in budget.source
    # a share is of the cgroup's limit, a size is taken as given
    half = find_budget(MemoryLimit("percent", 50, "50%"), proc=proc, cgroup=cgroup)
    assert half is not None and half.bytes == 2 * GIB
    assert "50% of the cgroup's limit 4.0 GiB" in half.source
    sized = find_budget(MemoryLimit("size", GIB, "1G"), proc=proc, cgroup=cgroup)
    assert sized is not None and sized.bytes == GIB and sized.source == "--memory-limit 1G"


def test_a_cgroup_v1_limit_counts_and_its_unlimited_value_does_not(tmp_path: Path) -> None:
    v1 = "4:memory:/process_api/abc\n0::/\n"
    proc, cgroup = _system(tmp_path, cgroup=v1, files={
        "memory/process_api/abc/memory.limit_in_bytes": f"{3 * GIB}\n",
        "memory/memory.limit_in_bytes": "9223372036854771712\n"})
    budget = find_budget(MemoryLimit(), proc=proc, cgroup=cgroup)
    assert budget is not None and budget.cgroup_v1 and budget.total == 3 * GIB
    proc, cgroup = _system(tmp_path / "unlimited", cgroup=v1, files={
        "memory/process_api/abc/memory.limit_in_bytes": "9223372036854771712\n"})
    budget = find_budget(MemoryLimit(), proc=proc, cgroup=cgroup)
    assert budget is not None and budget.cgroup is None and budget.total == 16 * GIB


def test_a_cgroup_limit_above_the_machines_memory_is_no_limit(tmp_path: Path) -> None:
    proc, cgroup = _system(tmp_path, files={"user.slice/job/memory.max": f"{64 * GIB}\n"})
    budget = find_budget(MemoryLimit(), proc=proc, cgroup=cgroup)
    assert budget is not None and budget.cgroup is None


def test_free_memory_in_a_cgroup_counts_its_inactive_page_cache_as_free(tmp_path: Path) -> None:
    proc, cgroup = _system(tmp_path, files={
        "user.slice/job/memory.max": f"{4 * GIB}\n",
        "user.slice/job/memory.current": f"{3 * GIB}\n",
        "user.slice/job/memory.stat": f"anon 1\ninactive_file {GIB}\nactive_file 5\n"})
    budget = find_budget(MemoryLimit(), proc=proc, cgroup=cgroup)
    assert budget is not None
    assert free_memory(budget, proc) == 2 * GIB
    machine = find_budget(MemoryLimit(), proc=proc, cgroup=tmp_path / "none")
    assert machine is not None and free_memory(machine, proc) == 10 * GIB
