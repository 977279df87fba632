"""A package's job carried out as the plan decided it: up to date; cut off when nothing it read
of its dependencies changed, or restored from the build cache (builder/reuse.py); else built
(builder/package.py). A failure of the machine (a full disk, a read-only install base, a
missing program) is the package's failure in one line, not a bug; a failed package's report
ends with the build dependencies it declared that were not found (builder/failure.py)."""

from __future__ import annotations

from wsbuild.builder.failure import with_unresolved
from wsbuild.builder.job import PackageJob, RunResources
from wsbuild.builder.package import PackageBuild
from wsbuild.builder.plan import Decision, PackagePlan
from wsbuild.builder.reuse import cut_off, restore
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.errors import environment_failure


def execute(planned: PackagePlan, run: RunResources) -> JobResult:
    """The job of `planned`, done."""
    job = PackageJob(planned, run)
    try:
        result = _carry_out(job)
    except OSError as exc:
        program = exc.filename if isinstance(exc, FileNotFoundError) \
            and isinstance(exc.filename, str) and "/" not in exc.filename else None
        message = environment_failure(exc, doing=f"building {job.name}", program=program)
        if message is None:
            raise
        result = JobResult(job.name, Outcome.FAILED, job._seconds(), message=message)
    return with_unresolved(result, run.unresolved.get(job.name, ()), run.selection, run.session)


def _carry_out(job: PackageJob) -> JobResult:
    planned = job.planned
    if planned.decision is Decision.UP_TO_DATE:
        return JobResult(job.name, Outcome.UP_TO_DATE, job._seconds())
    cut = cut_off(job)
    if cut is not None:
        return cut
    job.log_dir.mkdir(parents=True, exist_ok=True)
    job._log(f"Rebuilding: {planned.reason.text if planned.reason else ''}")
    if planned.decision is Decision.RESTORE:
        job.mark_unfinished()
        restored = restore(job)
        if restored is not None:
            return restored
    return PackageBuild(planned, job.run, started=job.started,
                        started_ns=job.started_ns).build()
