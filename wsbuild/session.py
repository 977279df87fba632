"""What one run holds, entered alike by `build`, `build --dry-run` and `test`: the install layout
it works on, the workspace lock, the ROS underlay's environment, the run's log directory, the
build cache and the jobserver. A dry run holds no lock, writes no log and repairs nothing."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator, Mapping
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.build_types import get_build_type
from wsbuild.cache.run import RunCache
from wsbuild.cache.settings import CacheSettings
from wsbuild.engine.jobserver import Jobserver
from wsbuild.events import Emit, Notice
from wsbuild.files import create_if_missing, private_directory
from wsbuild.prefix.layout import (
    IGNORE_MARKER, mark_install_layout, resolve_layout, write_ignore_marker)
from wsbuild.record.outside import Digests

if TYPE_CHECKING:
    from wsbuild.observe.library import Observer
    from wsbuild.record.dirty import Environment
    from wsbuild.record.file_digests import FileDigests
from wsbuild.underlay.environment import PreparedUnderlay, prepare_underlay
from wsbuild.workspace.root import BUILD_MARKER, Workspace

#: set to 0, nothing is observed (every package then builds every time): what benchmarks/
#: compares a build with observing against
OBSERVE_VARIABLE = "WSBUILD_OBSERVE"
#: where the stand-ins for ament linters without a wheel are written (underlay/lint.py)
LINT_SHIM = Path(".wsbuild") / "lint_shim"


@dataclass(frozen=True, slots=True)
class SessionOptions:
    """How a run enters the workspace."""

    verb: str
    #: None: whatever install/ holds (`test`); True/False: what the run asks for (`build`)
    merge_install: bool | None = None
    dry_run: bool = False
    wait_for_lock: bool = True
    repair_underlay: bool = True
    #: the build cache; None: off
    cache: CacheSettings | None = None
    #: a symlink install points into src/ and build/: nothing a cache could carry
    symlink_install: bool = False
    #: the CPU budget the jobserver shares among every package's build
    jobs: int = 1
    #: environment variables the user names as no input of any build (`--env-ignore`, the
    #: defaults file's `env-ignore`), besides record/environment.py's own list
    env_ignore: tuple[str, ...] = ()


@dataclass(slots=True)
class Session:
    """One run's context: workspace, install layout, underlay, log, cache and jobserver."""

    workspace: Workspace
    options: SessionOptions
    merged: bool
    underlay: PreparedUnderlay
    #: log/<verb>_<time>/; None for a dry run
    run_log: Path | None
    cache: RunCache
    #: what a dry run's underlay check found the build would first do
    notices: tuple[str, ...] = ()
    _jobserver: Jobserver | None = field(default=None)
    #: the outside files' and listings' digests taken in this run (record/outside.py)
    digests: Digests = field(default_factory=Digests)
    _environ: dict[str, str] | None = field(default=None)
    _facts: dict[str, object] = field(default_factory=dict)
    _observer: Observer | str | None = field(default=None)
    _environment: Environment | None = field(default=None)

    @property
    def environ(self) -> Mapping[str, str]:
        """The environment every package's build or test step starts from: the underlay
        applied, less what a terminal sets for itself, with a fixed locale
        (observe/step_environment.py)."""
        if self._environ is None:
            from wsbuild.observe.step_environment import step_base  # lazy: off `info`

            self._environ = step_base(self.underlay.environ)
        return self._environ

    def facts(self, build_type: str) -> object:
        """What a build type finds once per run (`BuildType.run_facts`: the tools it runs),
        resolved when first asked for."""
        if build_type not in self._facts:
            self._facts[build_type] = get_build_type(build_type).run_facts(self.environ)
        return self._facts[build_type]

    @property
    def environment(self) -> Environment:
        """`environ` as records compare it (record/dirty.py)."""
        if self._environment is None:  # (one for the run: it keeps what it worked out)
            from wsbuild.record.dirty import Environment  # lazy: off `info`

            self._environment = Environment(self.environ,
                                            own_install=str(self.workspace.install_base),
                                            ignored=self.options.env_ignore)
        return self._environment

    @property
    def observer(self) -> Observer | str:
        """The step observer (observe/library.py), built when a step first needs it; else
        why there is none."""
        if self._observer is None:
            from wsbuild.observe.library import home, observer  # lazy: off `info`

            if os.environ.get(OBSERVE_VARIABLE) == "0":  # benchmarks/: the cost of observing
                self._observer = f"observing is off ({OBSERVE_VARIABLE}=0)"
            else:
                self._observer = observer(home(os.environ), self.environ)
        return self._observer

    @property
    def underlay_prefixes(self) -> list[Path]:
        """Prefixes the dependency check searches besides the environment's (the venv)."""
        return [self.underlay.venv] if self.underlay.venv else []

    def jobserver(self, jobs: int | None = None) -> Jobserver:
        """The run's jobserver, made when the first package needs it (a no-op makes none),
        holding `jobs` (default: the local cores; more when compiles go to other hosts)."""
        if self._jobserver is None:
            self._jobserver = Jobserver(jobs or self.options.jobs)
        return self._jobserver

    def close(self) -> None:
        if not self.options.dry_run:
            from wsbuild.record.file_digests import save_file_digests  # lazy: off `info`
            from wsbuild.record.memo import save_memos  # lazy: off `info`

            save_memos()
            save_file_digests()
        if self._jobserver is not None:
            self._jobserver.close()
            self._jobserver = None
        self.cache.close()


@contextmanager
def open_session(workspace: Workspace, options: SessionOptions, emit: Emit) -> Iterator[Session]:
    """Enter a run: check the install layout, take the lock, prepare the underlay (repairing
    it, unless a dry run), make the run's log directory. Everything is released on exit."""
    from wsbuild.engine.lock import workspace_lock  # lazy: off `info`
    from wsbuild.engine.logs import new_run_log  # lazy: off `info`

    merged = resolve_layout(workspace.install_base, options.merge_install, verb=options.verb,
                            build_base=workspace.build_base)
    with ExitStack() as stack:
        if not options.dry_run:
            stack.enter_context(workspace_lock(workspace.build_base, wait=options.wait_for_lock,
                                               on_wait=lambda text: emit(Notice(text))))
            if options.verb == "build":
                _prepare_install(workspace, merged)
        notices: list[str] = []
        underlay = prepare_underlay(os.environ, executable=sys.executable,
                                    repair=options.repair_underlay,
                                    shim_dir=workspace.build_base / LINT_SHIM,
                                    notice=notices.append if options.dry_run
                                    else lambda text: emit(Notice(text)),
                                    dry_run=options.dry_run)
        # colcon's marker: a package crawl (colcon's, wsbuild's) never descends into log/
        run_log = None if options.dry_run else new_run_log(
            workspace.log_base, options.verb, markers=(IGNORE_MARKER,))
        cache = RunCache(options.cache, workspace, emit, symlink_install=options.symlink_install,
                         log=run_log / "cache.log" if run_log is not None else None)
        session = Session(workspace, options, merged, underlay, run_log, cache, tuple(notices))
        cache.environment = session.environment
        session.digests.kept = _kept_digests()
        if merged:  # a listing in the shared prefix leaves out the other packages' entries
            from wsbuild.prefix.stage import MERGED_RECORD  # lazy: off `info` and `build --dry-run`
            from wsbuild.record.merged_owners import register  # lazy: off `info`

            register(workspace.install_base, workspace.build_base, MERGED_RECORD)
        try:
            yield session
        finally:
            session.close()


def _kept_digests() -> FileDigests:
    """The digests of files earlier runs took (record/file_digests.py), beside the observer."""
    from wsbuild.observe.library import home  # lazy: off `info`
    from wsbuild.record.file_digests import file_digests  # lazy: off `info`

    return file_digests(home(os.environ))


def _prepare_install(workspace: Workspace, merged: bool) -> None:
    """build/ and install/ get colcon's markers, so tools and later runs recognise them; a
    previous install an interrupted run parked is put back."""
    from wsbuild.prefix.stage import recover_all  # lazy: off `info` and `build --dry-run`

    for base in (workspace.build_base, workspace.install_base):
        base.mkdir(parents=True, exist_ok=True)
        write_ignore_marker(base)
    # records, memos and the lint stand-ins: wsbuild's own, private to the user
    private_directory(workspace.build_base / ".wsbuild")
    create_if_missing(workspace.build_base / BUILD_MARKER, "wsbuild\n")
    mark_install_layout(workspace.install_base, merged=merged)
    if not merged:
        recover_all(workspace.install_base)
