"""What keeps the jobs of a CI matrix on one split, and the assembling job's check that they
covered the workspace (`build --shard K/N`, `test --shard K/N`, `build --assemble N`).

- The run: the CI's run id when wsbuild knows one (builder/shards/split.py's `shard_run_id`), else
  the commit's workspace itself: a digest of the selected packages, their dependencies and
  the content of their files, the same in every job that checked out the same commit.
- The times a run's split is balanced on are fixed for the run: the first job of the run
  copies the shared times document (cache/documents.py) into one of the run's own; every job
  of the run then splits on that copy, whatever the shards that finished meanwhile
  published, so every job computes the same split.
- `test --shard K/N` notes which packages it tested; `build --assemble N` (the job after the
  matrix) fails, naming them, when a selected package was built by no shard (no entry this
  job can restore) or tested by none.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.builder.shards.split import digest
from wsbuild.cache.documents import SharedDocuments
from wsbuild.errors import BuildFailed
from wsbuild.record.model import read_record
from wsbuild.record.own_files import own_files
from wsbuild.words import plural

if TYPE_CHECKING:
    from wsbuild.builder.shards.split import Assembly
    from wsbuild.cache.settings import CacheSettings
    from wsbuild.workspace.selection import Selection

#: the shared document of recorded build times every run starts from (builder/shards/run.py)
TIMES = "package times"


def times_name(run: str) -> str:
    """The times document fixed for `run`."""
    return f"package times for {run}"


def tested_name(run: str, count: int, index: int) -> str:
    """What shard `index` of `count` of `run` tested."""
    return f"shard tests {run} {count} {index}"


def run_of(selection: Selection, known: str) -> str:
    """The run the jobs of a matrix share: `known` (the CI's run id) if any, else the
    commit's workspace (`workspace_digest`)."""
    return known or f"workspace-{workspace_digest(selection)}"


def workspace_digest(selection: Selection) -> str:
    """The selected packages, their dependencies among them and their files' contents: what
    every job that checked out one commit shares. A package's record spares hashing the
    files whose stat signature it already holds."""
    ws = selection.workspace
    outputs = tuple(str(base) for base in (ws.build_base, ws.install_base, ws.log_base))
    selected = set(selection.selected)
    parts = []
    for name in sorted(selection.selected):
        record = read_record(ws.build_base / name)
        own = own_files(selection.packages[name].path, record.own if record else {}, outputs)
        parts.append([name, own.digest, sorted(selection.graph.direct(name) & selected)])
    return digest(parts)


def _times_of(value: Mapping[str, object] | None) -> dict[str, float] | None:
    times = value.get("times") if value is not None else None
    if not isinstance(times, dict):
        return None
    return {str(k): float(v) for k, v in times.items()
            if isinstance(v, (int, float)) and not isinstance(v, bool) and v >= 0}


def shared_times(documents: SharedDocuments) -> dict[str, float] | None:
    """The shared times document: each package's build time the shards recorded last."""
    return _times_of(documents.get(TIMES))


def run_times(documents: SharedDocuments, run: str, *, fix: bool,
              scratch: Path | None = None) -> dict[str, float] | None:
    """The times the run's split is balanced on: the run's own copy; else the shared times
    document, copied for the run when `fix` (the first job of the run). None when the server
    has neither."""
    fixed = _times_of(documents.get(times_name(run)))
    if fixed is not None:
        return fixed
    shared = shared_times(documents)
    if fix and scratch is not None:
        documents.put(times_name(run), {"times": shared or {}}, "times", scratch)
    return shared


def note_tested(settings: CacheSettings | None, run: str, count: int, index: int,
                tested: Sequence[str], scratch: Path) -> list[str]:
    """Write which packages shard `index` tested, for the assembling job. Returns what could
    not be written."""
    documents = SharedDocuments.open(settings)
    if documents is None:
        return []
    try:
        documents.put(tested_name(run, count, index), {"tested": sorted(tested)}, "tests",
                      scratch)
        return list(documents.problems)
    finally:
        documents.close()


def check_assembly(building: Sequence[str], selection: Selection, assembly: Assembly,
                   settings: CacheSettings | None) -> list[str]:
    """`build --assemble N`: raise BuildFailed naming the selected packages no shard built
    (`building`: the plan would build them, with no entry this job can restore, nor an
    install here) or tested (no shard's note names them). Returns the lines to say when all
    is covered."""
    count, run = assembly.count, run_of(selection, assembly.run)
    unbuilt = sorted(building)
    tested: set[str] = set()
    noted: list[int] = []
    documents = SharedDocuments.open(settings)
    if documents is not None:
        try:
            for index in range(1, count + 1):
                note = documents.get(tested_name(run, count, index))
                names = note.get("tested") if note is not None else None
                if isinstance(names, list):
                    noted.append(index)
                    tested.update(str(name) for name in names)
        finally:
            documents.close()
    untested = sorted(set(selection.selected) - tested) if noted else []
    problems = []
    if unbuilt:
        problems.append(f"not built by any shard: {' '.join(unbuilt)}")
    if untested:
        silent = [f"{index}/{count}" for index in range(1, count + 1) if index not in noted]
        why = f"; shard {', '.join(silent)} noted no test run" if silent else ""
        problems.append(f"not tested by any shard: {' '.join(untested)}{why}")
    if problems:
        raise BuildFailed(
            f"the {count} shards of this run left {plural(len(set(unbuilt) | set(untested)), 'package')} "
            f"out ({'; '.join(problems)})",
            hint="see each shard job's log (did every job of the matrix run to its end, on "
                 "the same commit?)")
    if not noted:
        return [f"assembled {plural(len(selection.selected), 'package')} of {count} shards; "
                "no shard noted a test run (`wsbuild test --shard K/N`): tests not checked"]
    return [f"assembled {plural(len(selection.selected), 'package')}: every one built and "
            f"tested by one of the {count} shards"]
