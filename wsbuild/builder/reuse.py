"""A package's build that runs no step: restored from the build cache (the entry's record
proved on this machine again, with its dependencies as this run left them), or cut off (its
dependencies were rebuilt before it in this run, and nothing it read of them changed, the
variables their hooks set included): builder/records.py makes the record it keeps."""

from __future__ import annotations

from typing import TYPE_CHECKING

from wsbuild.builder.context import make_context
from wsbuild.builder.plan import BUILDING_MARKER
from wsbuild.builder.records import cut_off_record, restored_record
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.events import CacheRestored
from wsbuild.record.dirty import Environment, cutoff_note
from wsbuild.record.model import write_record

if TYPE_CHECKING:
    from wsbuild.builder.job import PackageJob


def restore(build: PackageJob) -> JobResult | None:
    """Install the build cache's entry the plan found, once this machine proves it again
    with its dependencies as this run left them; None when it is refused (the package is
    then built). The package's record becomes the entry's (builder/records.py)."""
    planned = build.planned
    assert planned.cache_key is not None and planned.cache_entry is not None
    session = build.run.session
    key = planned.cache_entry.key or planned.cache_key
    restored = session.cache.restore(
        key, planned.cache_entry.found, build.prefix, build.merged_record,
        inputs_key=planned.inputs_key, dependencies=build.dependency_keys(),
        digests=session.digests)
    if isinstance(restored, str):
        build._log(f"Not restored from the build cache: {restored}")
        return None
    entry, entry_record, installed = restored
    write_record(build.build_dir, restored_record(
        planned, entry_record, installed,
        install_base=build.run.selection.workspace.install_base, digests=session.digests))
    (build.build_dir / BUILDING_MARKER).unlink(missing_ok=True)
    build._log(f"Restored from the build cache ({entry.source}, archive {entry.digest})")
    build.run.emit(CacheRestored(build.name, entry.source))
    return JobResult(build.name, Outcome.FINISHED, build._seconds(), log_dir=build.log_dir,
                     message="restored from cache", restored=True)


def cut_off(build: PackageJob) -> JobResult | None:
    """A package planned to build only if what it read of its dependencies (built before
    it in this run) changed: up to date when nothing did, its record refreshed."""
    planned = build.planned
    if planned.reason is None or not planned.reason.cutoff or planned.previous is None:
        return None
    dependencies = build.dependency_keys()
    record = cut_off_record(planned, dependencies,
                            install_base=build.run.selection.workspace.install_base,
                            digests=build.run.session.digests,
                            environment=environment_now(build))
    if record is None:
        return None
    write_record(build.build_dir, record)
    return JobResult(build.name, Outcome.UP_TO_DATE, build._seconds(),
                     message=cutoff_note(planned.previous, dependencies))


def environment_now(build: PackageJob) -> Environment:
    """What the package's steps would see now, its dependencies (built before it in this
    run) applied: a dependency's hook may set what a step reads."""
    session = build.run.session
    ctx = make_context(build.run.selection, session, build.name, prefix=build.prefix,
                       options=build.planned.options.applied_to(build.run.options))
    environ = dict(ctx.environ)
    for step in build.planned.steps:
        if step.command is not None:
            environ.update(step.command.env)
    return Environment(environ, own_install=str(build.run.selection.workspace.install_base),
                       ignored=session.options.env_ignore)
