"""One package's job in a build as the plan decided it (builder/plan.py): what every job of the
run shares, read-only (`RunResources`), and what every way of carrying out a decision needs
(`PackageJob`: the package's directories, its log, its unfinished mark, its dependencies'
keys). builder/execute.py picks the way: up to date, cut off or restored (builder/reuse.py),
or built (builder/package.py)."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.builder.plan import BUILDING_MARKER, PackagePlan
from wsbuild.builder.records import dependency_keys
from wsbuild.engine.logs import append_command_log
from wsbuild.files import private_directory
from wsbuild.prefix.stage import MERGED_RECORD

if TYPE_CHECKING:
    from wsbuild.build_types import BuildOptions
    from wsbuild.builder.resources.compiler_cache import CompilerCache
    from wsbuild.builder.resources.distcc import Distribution
    from wsbuild.engine.jobserver import Jobserver
    from wsbuild.events import Emit
    from wsbuild.session import Session
    from wsbuild.workspace.selection import Selection


@dataclass(frozen=True, slots=True)
class RunResources:
    """What every package build of one run shares, read-only."""

    selection: Selection
    session: Session
    #: the plan's options with the run's compiler launcher
    options: BuildOptions
    run_log: Path
    jobserver: Jobserver
    compilers: CompilerCache | None
    emit: Emit
    #: package -> its unresolved build dependencies, named when it fails
    unresolved: Mapping[str, tuple[str, ...]]
    #: topological order of the whole workspace: dependencies' prefixes are applied in it
    order: tuple[str, ...]
    #: distcc for the run's compiles (--distribute); None: compile here only
    distribution: Distribution | None = None
    #: a package whose steps read another's install without declaring it fails
    #: (--strict-dependencies), instead of being warned about
    strict_dependencies: bool = False
    #: returns when a command step may start (the memory governor, engine/memory.py)
    memory_gate: Callable[[str, str, Emit], None] | None = None


@dataclass(slots=True)
class PackageJob:
    """One package's job: its plan and the run's resources."""

    planned: PackagePlan
    run: RunResources
    started: float = field(default_factory=time.monotonic)
    #: the wall clock at the start: an outside file changed since may have changed unseen
    started_ns: int = field(default_factory=time.time_ns)

    @property
    def name(self) -> str:
        return self.planned.name

    @property
    def build_dir(self) -> Path:
        return self.run.selection.workspace.build_base / self.name

    @property
    def log_dir(self) -> Path:
        return self.run.run_log / self.name

    @property
    def prefix(self) -> Path:
        return self.planned.prefix

    @property
    def merged_record(self) -> Path | None:
        return self.build_dir / MERGED_RECORD if self.run.session.merged else None

    def dependency_keys(self) -> dict[str, str]:
        """The keys of the package's dependencies as this run left them (builder/records.py)."""
        return dependency_keys(self.planned, self.run.selection.workspace.build_base)

    def mark_unfinished(self) -> None:
        """Until the package's new record is written, its last build counts as unfinished."""
        marker = self.build_dir / BUILDING_MARKER
        private_directory(marker.parent)
        marker.touch(mode=0o600)
        marker.write_text("")  # not (yet) failed: cut short, if this run ends here

    def _log(self, line: str) -> None:
        append_command_log(self.log_dir, line)

    def _seconds(self) -> float:
        return time.monotonic() - self.started
