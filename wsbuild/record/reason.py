"""The words every "still valid?" question answers in (cargo's `DirtyReason`): a typed kind
of change, a text for people and what changed. The package's dirty check (record/dirty.py),
a cached test result (record/tested.py), a configure (record/configured.py) and a command's
recording (engine/replay.py, through record/environment.py) all answer with a `Reason`; this
module imports nothing, so that a replay can ask too."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


class Dirty(str, Enum):
    """What kind of change makes a package build, in the order the check looks for them (the
    value is what `--dry-run --json` writes)."""

    #: its last build was cut short (the record says nothing then)
    UNFINISHED = "unfinished"
    #: the command line asks for it (--force, --cmake-force-configure, …)
    FORCED = "forced"
    #: it has no record: never built here, or built by another tool
    NEW = "new"
    #: the options it is built with (its build type's, --cmake-args, a mixin, a meta file)
    OPTIONS = "options"
    #: a variable of the environment its build sees
    ENVIRONMENT = "environment"
    #: one of its own files (by content)
    SOURCE = "source"
    #: a workspace dependency was rebuilt, and this build read what changed of it
    DEPENDENCY = "dependency"
    #: a file outside the package its build read (a header of the underlay, a tool)
    EXTERNAL = "external"
    #: what it installed is missing or changed under install/
    INSTALL = "install"
    #: its steps were not all observed: its build system runs every time
    UNOBSERVED = "unobserved"
    #: its build system had work left right after its last build: it runs every time
    VOLATILE = "volatile"
    #: (a configure) the last run of the step, or of a later one, read what changed since
    REREAD = "reread"
    #: (a test result) its package was rebuilt since its tests passed
    REBUILT = "rebuilt"
    #: (a test result) the result files its run wrote changed or are gone
    RESULTS = "results"

    def __str__(self) -> str:
        return self.value


@dataclass(frozen=True, slots=True)
class Reason:
    """Why a package is built: `kind` for tools, `text` for people, `details` the files,
    options, variables or dependencies that changed."""

    kind: Dirty
    text: str
    details: tuple[str, ...] = ()
    #: decided once the dependencies in `details` are built in this run: built only if what
    #: it read of them changed (early cutoff), else up to date
    cutoff: bool = False
    #: the labels of the steps that read what changed (record.read_by): a build type redoes
    #: from the first of them (CMake configures again when its configure read it)
    redo: tuple[str, ...] = ()
