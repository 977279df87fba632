"""A package's context as the builder makes it, for the plan, the build and `--dry-run` alike:
its dependencies' prefixes applied to the session's environment (what sourcing them would do),
its options (the run's, then its own), its build type's facts of the run, and what its build
directory holds (`build_types.package_context`, the one function that makes every context, also
the by-hand command's). What only a running build has (the jobserver's descriptors, the
compiler cache's and distcc's private files, a stage) comes in as `run_environ` and the
arguments after it; a context made for the plan has none of them."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

from wsbuild.build_types import (
    BuildOptions,
    PackageContext,
    Problems,
    CommandRunner,
    Step,
    StepFailed,
    StepObserver,
    get_build_type,
    package_context,
)
from wsbuild.prefix import environment_for
from wsbuild.prefix.layout import is_installed, package_prefix
from wsbuild.prefix.stage import stage_path
from wsbuild.session import Session
from wsbuild.workspace.selection import Selection

#: stands for the jobserver every build has (engine/jobserver.py) in a context made for the
#: plan, so that the steps are decided as the build decides them (a Ninja that joins it gets no
#: fixed `--parallel`); the build puts the run's FIFO in its place
RUN_JOBSERVER = Path("<the run's jobserver FIFO>")


def make_context(selection: Selection, session: Session, name: str, *, prefix: Path,
                 options: BuildOptions, stage_prefix: Path | None = None,
                 run_environ: Mapping[str, str] | None = None, run: CommandRunner | None = None,
                 warn: Callable[[str], None] | None = None,
                 jobserver_fifo: Path | None = None, redo: tuple[str, ...] = (),
                 observe: StepObserver | None = None) -> PackageContext:
    """Package `name`'s context (see the module's docstring); without `run`, a context that
    runs nothing (the plan's, `--dry-run`'s)."""
    workspace = selection.workspace
    closure = selection.graph.build_closure(name)
    merged = session.merged
    # the dependencies' prefixes, applied in dependency order (as far as they are installed)
    dependencies = [(package_prefix(workspace.install_base, dep, merged=merged), dep)
                    for dep in selection.graph.topological_order() if dep in closure
                    and is_installed(workspace.install_base, dep, merged=merged)]
    environ = environment_for(dependencies, session.environ)
    environ.update(run_environ or {})
    package = selection.packages[name]
    build_type = get_build_type(package.build_type)
    return package_context(
        build_type, package=package, build_dir=workspace.build_base / name,
        install_prefix=prefix, stage_prefix=stage_prefix or prefix, options=options,
        environ=environ, run=run or _not_run, warn=warn or (lambda _text: None),
        dependency_prefixes=[prefix for prefix, _ in dependencies],
        jobserver_fifo=jobserver_fifo if jobserver_fifo is not None else RUN_JOBSERVER,
        facts=session.facts(package.build_type), redo=redo, observe=observe)


def planned_steps(selection: Selection, session: Session, name: str, *, prefix: Path,
                  options: BuildOptions, redo: tuple[str, ...] = (), distributing: bool = False
                  ) -> tuple[tuple[Step, ...], Mapping[str, str]]:
    """Package `name`'s steps as the plan decides them, and the environment they start from:
    from a context made as the build makes its own, less what only a running build has. Of
    the run's resources, the plan knows only the local gate's CMake file of a distributed run
    (a stable path); where the run turns out otherwise (no distcc host answers), the build
    decides again (builder/package.py: `steps`)."""
    run_environ = {}
    if distributing:
        from wsbuild.builder.resources.distcc import (
            planned_environ)  # lazy: off the full no-op build

        run_environ = planned_environ(selection.workspace.build_base)
    ctx = make_context(selection, session, name, prefix=prefix, options=options,
                       stage_prefix=stage_path(selection.workspace.install_base, name),
                       redo=redo, run_environ=run_environ)
    return tuple(get_build_type(ctx.package.build_type).steps(ctx)), ctx.environ


def _not_run(command: object, *, cwd: Path, env: Mapping[str, str] | None = None,
             problems: Problems | None = None) -> None:
    """A planning context's `run`: deciding the steps runs no command."""
    raise StepFailed("a plan runs nothing", cwd=cwd)
