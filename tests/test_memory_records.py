"""engine/memory_records.py: what each package needed, kept beside the durations."""

from __future__ import annotations

import json
from pathlib import Path

from wsbuild.engine.memory_admission import Need
from wsbuild.engine.memory_records import (
    DRIVER_OVERHEAD,
    MEMORY_FILE,
    PackageMemoryRecord,
    StepMemory,
    merged,
    read_memory,
    record_memory,
)

M = 1024 * 1024
FULL = PackageMemoryRecord(700 * M, {"configure": StepMemory(40 * M, 15 * M, 2),
                                     "build": StepMemory(700 * M, 300 * M, 12),
                                     "install": StepMemory(5 * M)})


def test_a_record_round_trips_beside_the_durations_in_the_order_its_steps_ran(
        tmp_path: Path) -> None:
    record_memory(tmp_path, {"a": FULL})
    assert (tmp_path / MEMORY_FILE).parent == tmp_path / ".wsbuild"
    assert read_memory(tmp_path) == {"a": FULL}
    assert list(json.loads((tmp_path / MEMORY_FILE).read_text())["a"]["steps"]) == [
        "configure", "build", "install"]
    (tmp_path / MEMORY_FILE).write_text("{not json")
    assert read_memory(tmp_path) == {}


def test_what_a_package_and_each_step_needs_to_start() -> None:
    # the package starts with its first step; a step with a make or Ninja with its first job
    assert FULL.need() == Need(300 * M, 40 * M, True)
    assert FULL.need("build") == Need(300 * M, 300 * M + DRIVER_OVERHEAD, True)
    assert FULL.need("install") == Need(None, 5 * M, True)
    # a step never recorded needs the package's largest
    assert FULL.need("test") == Need(None, 700 * M, True)


def test_an_incremental_build_only_raises_and_a_full_one_replaces() -> None:
    one_file = PackageMemoryRecord(200 * M, {"build": StepMemory(200 * M, 180 * M, 1)})
    after = merged(FULL, one_file)
    assert after.steps["build"] == StepMemory(700 * M, 300 * M, 12)
    smaller = PackageMemoryRecord(400 * M, {"build": StepMemory(400 * M, 150 * M, 12)})
    assert merged(FULL, smaller).steps["build"] == StepMemory(400 * M, 150 * M, 12)
    assert merged(FULL, smaller).steps["configure"] == FULL.steps["configure"]
