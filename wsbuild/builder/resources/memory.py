"""A build's memory budget: found as `--memory-limit` asks (engine/memory_budget.py), the
governor that admits the packages and decides the jobserver's tokens by it (engine/memory.py)
started with what each package is recorded to need (engine/memory_records.py), and at the end
what the packages built in the run needed, recorded for the next run."""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.engine.memory_budget import MemoryBudget, MemoryLimit, find_budget

if TYPE_CHECKING:
    from wsbuild.cache.documents import SharedDocuments
    from wsbuild.cache.settings import CacheSettings
    from wsbuild.engine.jobserver import Jobserver
    from wsbuild.engine.memory import MemoryGovernor, MemoryUse
    from wsbuild.engine.memory_records import PackageMemoryRecord


def budget_of(limit: MemoryLimit) -> MemoryBudget | None:
    """The run's budget (None: `--no-memory-limit`, or a system that tells nothing)."""
    return find_budget(limit)


def budget_line(limit: MemoryLimit) -> str:
    """What `--dry-run` says of the budget: its size and where it came from."""
    if limit.off:
        return "memory budget: none (--no-memory-limit): packages and jobs start as the CPUs allow"
    budget = budget_of(limit)
    if budget is None:
        return "memory budget: none (the system tells no memory figures)"
    return f"memory budget: {budget.text()}"


def budget_json(limit: MemoryLimit) -> dict[str, object] | None:
    """The budget as `--dry-run --json` gives it (None: no budget)."""
    budget = budget_of(limit)
    return budget.as_json() if budget is not None else None


def open_governor(limit: MemoryLimit, restoring: Sequence[str], build_base: Path,
                  jobserver: Jobserver, warn: Callable[[str], None],
                  shared: Mapping[str, PackageMemoryRecord] | None = None,
                  workers: int | None = None) -> MemoryGovernor | None:
    """The run's memory governor, started (None: no budget). `restoring`: the packages the
    plan restores from the build cache (light: they run no step); `shared`: what a CI
    matrix's other jobs recorded (builder/shards/run.py), under this workspace's own records."""
    budget = budget_of(limit)
    if budget is None:
        return None
    from wsbuild.engine.memory import MemoryGovernor  # lazy: off the full no-op build
    from wsbuild.engine.memory_records import read_memory  # lazy: off the full no-op build

    predictions = {**(shared or {}), **read_memory(build_base)}
    return MemoryGovernor(budget, jobserver, predictions, warn=warn, light=list(restoring),
                          workers=workers).start()


def finish_memory(governor: MemoryGovernor | None, build_base: Path,
                  results: Sequence[JobResult], building: Collection[str]) -> MemoryUse | None:
    """Stop measuring; record what each package the plan built (`building`; not restored)
    needed in the run."""
    if governor is None:
        return None
    from wsbuild.engine.memory_records import record_memory  # lazy: off the full no-op build

    use = governor.stop()
    built = set(building)
    finished = {r.package for r in results if r.outcome is Outcome.FINISHED
                and not r.restored}
    record_memory(build_base, {name: record for name, record in use.packages.items()
                               if name in built & finished})
    return use


# ----------------------------------------------------------------------------- a CI matrix

#: the shared document of what each package needed (beside builder/shards/run.py's times)
MEMORY_DOCUMENT = "package memory"


def shared_memory(documents: SharedDocuments | None) -> dict[str, PackageMemoryRecord]:
    """What the jobs of a CI matrix recorded each package to need (empty: none yet)."""
    if documents is None:
        return {}
    from wsbuild.engine.memory_records import records_from_json  # lazy: off the full no-op build

    value = documents.get(MEMORY_DOCUMENT)
    return records_from_json(value.get("memory")) if value is not None else {}


def publish_memory(settings: CacheSettings | None, names: Collection[str],
                   build_base: Path) -> list[str]:
    """Merge what the packages `names` (built here) needed, as this workspace recorded it,
    into the server's shared document. Returns what could not be done."""
    from wsbuild.cache.documents import SharedDocuments  # lazy: off the full no-op build
    from wsbuild.engine.memory_records import merged, read_memory  # lazy: off the full no-op build

    local = read_memory(build_base)
    ours = {name: local[name] for name in names if name in local}
    documents = SharedDocuments.open(settings)
    if documents is None or not ours:
        return []
    try:
        known = shared_memory(documents)
        for name, record in ours.items():
            known[name] = merged(known.get(name), record)
        documents.put(MEMORY_DOCUMENT, {"memory": {name: known[name].as_json()
                                                   for name in sorted(known)}},
                      "memory", build_base / ".wsbuild")
        return list(documents.problems)
    finally:
        documents.close()
