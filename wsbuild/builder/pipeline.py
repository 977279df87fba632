"""`wsbuild build`: plan, then execute. The stages, in order (each names the module that does it):

1. verbs/load.py          workspace/discover → manifest → graph → selection (what to build)
2. session.py             the run's context: install layout checked (prefix/layout.py), the
                          workspace lock (engine/lock.py), the ROS underlay detected, repaired and
                          its environment computed (underlay/), the run's log (engine/logs.py), the
                          build cache (cache/run.py) and the jobserver (engine/jobserver.py),
                          with distcc's hosts probed and counted in it (builder/resources/distcc.py)
3. builder/plan.py        the plan: per package up to date / restore / build, the reason, the keys;
                          unresolved build dependencies (workspace/resolve.py), overrides
                          (builder/overrides.py), the start order and critical path. `--dry-run`
                          prints it (builder/plan_text.py) and stops here
4. builder/package.py     the packages to restore or build run in parallel, in the order of
                          the plan's ready queue (runreport/package_run.py → engine/schedule.py),
                          each through its build type's steps (build_types/) into a stage
                          (prefix/stage.py), registered (prefix/hooks.py) and committed
5. builder/finish.py      install/setup.* and local_setup.*, compile_commands.json
6. runreport/            log/<run>/timings.json, report.json and report.html: timeline, CPU use,
                          packages (runreport/package_run.py, as for `wsbuild test`)
7. reporter.py            events (events.py) become console lines and the summary
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, replace

from typing import TYPE_CHECKING

from wsbuild.build_types import get_build_type
from wsbuild.builder.plan import BuildPlan, Decision, make_plan
from wsbuild.builder.request import BuildRequest
from wsbuild.builder.overrides import override_warning
from wsbuild.engine.jobs import JobFinished, JobResult, JobStarted, Outcome
from wsbuild.engine.schedule import FailurePolicy, RunInterrupted
from wsbuild.engine.timings import CompileJobs, cpu_times, record_durations
from wsbuild.errors import BuildFailed, Interrupted
from wsbuild.events import Emit, NoOpFinished, Notice, PlanMade, RunFinished
from wsbuild.record.model import write_record
from wsbuild.session import Session, SessionOptions, open_session
from wsbuild.workspace.selection import Selection
from wsbuild.words import plural

from wsbuild.runreport.package_run import PackageRun
from wsbuild.runreport.report_json import RunFacts

if TYPE_CHECKING:  # what only packages to build need: a no-op imports none of it
    from wsbuild.build_types import BuildType
    from wsbuild.builder.resources.compiler_cache import CacheCounts, CompilerCache
    from wsbuild.builder.resources.distcc import Distribution
    from wsbuild.builder.plan_text import PlannedCommands
    from wsbuild.builder.shards.run import ShardPlan


def session_options(request: BuildRequest, *, dry_run: bool = False) -> SessionOptions:
    return SessionOptions(verb="build", merge_install=request.build.merge_install,
                          dry_run=dry_run, wait_for_lock=request.run.wait_for_lock,
                          repair_underlay=request.repair_underlay, cache=request.cache,
                          symlink_install=request.build.symlink_install, jobs=request.build.jobs,
                          env_ignore=request.env_ignore)


def _shard_and_plan(selection: Selection, request: BuildRequest, session: Session
                    ) -> tuple[Selection, ShardPlan | None, BuildPlan]:
    """The plan; with `--shard K/N` first the shard's packages and those of other shards they
    need, ranked by their work in the whole split (builder/shards/run.py)."""
    if request.shard is None:
        return selection, None, make_plan(selection, request, session)
    from wsbuild.builder.shards.run import (
        shard_selection, with_waits)  # lazy: off the full no-op build

    selection, shard = shard_selection(selection, request.shard, request.run.workers, session)
    return selection, shard, with_waits(make_plan(selection, request, session,
                                                  priorities=shard.priorities), shard)


def plan_build(selection: Selection, request: BuildRequest, emit: Emit) -> BuildPlan:
    """`build --dry-run`: the plan the build would execute; nothing is touched."""
    with open_session(selection.workspace, session_options(request, dry_run=True),
                      emit) as session:
        return _shard_and_plan(selection, request, session)[2]


def dry_run(selection: Selection, request: BuildRequest, emit: Emit
            ) -> tuple[BuildPlan, PlannedCommands]:
    """`build --dry-run`: the plan, and the commands of each package it would build."""
    from wsbuild.builder.plan_text import planned_commands  # lazy: off the full no-op build

    with open_session(selection.workspace, session_options(request, dry_run=True),
                      emit) as session:
        selection, _shard, build_plan = _shard_and_plan(selection, request, session)
        return build_plan, planned_commands(build_plan, selection, session,
                                            compiler_cache=request.compiler_cache)


def run_build(selection: Selection, request: BuildRequest, emit: Emit) -> list[JobResult]:
    """Build the selected packages. Raises BuildFailed / Interrupted after reporting."""
    started = time.monotonic()
    cpu_before = cpu_times()
    with open_session(selection.workspace, session_options(request), emit) as session:
        if request.compiler_cache not in ("auto", "none"):  # a tool named must be there,
            from wsbuild.builder.resources.compiler_cache import (
                choose_tool)  # lazy: off the full no-op build

            choose_tool(request.compiler_cache, session.environ,
                        distributing=request.distribute is not None)
        selection, shard, plan = _shard_and_plan(selection, request, session)
        # a shard's run asks a server (the other shards' packages): never replayed
        # and so does the assembling job (what the shards noted)
        no_op = plan.refusal is None and not plan.to_do() and shard is None \
            and request.assemble is None
        emit(PlanMade(no_op=no_op))
        if plan.refusal is not None:
            raise plan.refusal.error
        _warn(plan, emit, selection, session)
        if request.assemble is not None:  # every package built and tested by a shard
            from wsbuild.builder.shards.cover import (
                check_assembly)  # lazy: off the full no-op build

            building = [p.name for p in plan.packages if p.decision is Decision.BUILD]
            for line in check_assembly(building, selection, request.assemble,
                                       session.cache.settings):
                emit(Notice(line))
        assert session.run_log is not None
        if shard is not None:  # its note for the other shards (builder/shards/run.py)
            from wsbuild.builder.shards import run as shard_run  # lazy: off the full no-op build

            shard_run.start(plan, shard, session, emit)
        run = PackageRun(selection, session.run_log, plan.jobs, report=request.report,
                         sample_cpu=bool(plan.to_do()), started=started, cpu_before=cpu_before)
        results, counts = execute(plan, selection, request, session, emit, run, shard=shard)
        details = _finish(run, request, session, results, counts, plan)
        if shard is not None:  # what it waited for; the times of what it built
            details += shard_run.finish(plan, shard, results, session, emit)
    seconds = time.monotonic() - started
    emit(RunFinished(tuple(results), seconds, details=details))
    failed = [r.package for r in results if r.outcome is Outcome.FAILED]
    if failed:
        raise BuildFailed(f"{plural(len(failed), 'package')} failed: {', '.join(failed)}",
                          hint=f"logs in {session.run_log}")
    if no_op and all(r.outcome is Outcome.UP_TO_DATE for r in results):
        assert session.run_log is not None
        emit(NoOpFinished(selection.workspace.build_base, selection.workspace.log_base,
                          session.run_log, seconds))
    return results


@dataclass(frozen=True, slots=True)
class CompileCounts:
    """What the run's compilers did: cache hits and misses, where distributed compiles ran."""

    cache: CacheCounts | None = None
    jobs: CompileJobs | None = None
    #: the jobserver's jobs when compiles were distributed (the local cores otherwise)
    budget: int = 0
    #: the compiler cache the run used ("" none: `auto` found none, or nothing was built)
    tool: str = ""


def execute(plan: BuildPlan, selection: Selection, request: BuildRequest, session: Session,
            emit: Emit, run: PackageRun, *, shard: ShardPlan | None = None
            ) -> tuple[list[JobResult], CompileCounts]:
    """Carry out the plan in `run`: up-to-date packages are settled in this thread, the others
    are restored or built by the scheduler's workers; then install/'s setup scripts."""
    from wsbuild.builder.finish import (
        merge_compile_commands,
        name_lint_stand_ins,
        write_setup_scripts,
    )  # lazy: off `build --dry-run` and `test`

    ws = selection.workspace
    assert session.run_log is not None
    settled = _settle_up_to_date(plan, session, run.timed(emit))
    compilers: CompilerCache | None = None
    distribution: Distribution | None = None
    counts = CompileCounts()
    # each build type of a package the run may build (a refused restore builds), opened for
    # the run and closed after it
    build_types = [get_build_type(name) for name in sorted({p.build_type for p in plan.to_do()})]
    try:
        for build_type in build_types:
            build_type.open_run(session.environ)
        if any(p.decision is Decision.BUILD for p in plan.packages):
            from wsbuild.builder.resources.compiler_cache import (
                open_compiler_cache)  # lazy: off the full no-op build

            compilers = open_compiler_cache(request.compiler_cache, session.environ,
                                            session.run_log / "sccache.log",
                                            distributing=request.distribute is not None)
            distribution = _open_distribution(request, session, emit)
        built = _run_packages(plan, selection, request, session, compilers, distribution,
                              run, emit, shard)
        session.cache.close()
        counts = _stop_compilers(compilers, distribution, emit)
    except RunInterrupted as interrupt:
        session.cache.close(wait=False)
        counts = _stop_compilers(compilers, distribution, emit)
        results = _in_selection_order(selection, {**settled, **_by_name(interrupt.results)})
        write_setup_scripts(ws, session.merged, session.underlay, installed_changed=True)
        details = _finish(run, request, session, results, counts, plan)
        emit(RunFinished(tuple(results), time.monotonic() - run.started, details=details))
        raise Interrupted("build interrupted") from None
    finally:
        run.sampler.stop()
        _after_packages(session, compilers, distribution, build_types)
    results = _in_selection_order(selection, {**settled, **_by_name(built)})
    write_setup_scripts(ws, session.merged, session.underlay,
                        installed_changed=any(r.outcome is Outcome.FINISHED for r in results))
    if any(r.outcome is Outcome.FINISHED for r in results):  # a no-op reads no file
        merge_compile_commands(ws)
    name_lint_stand_ins(ws, results, emit)
    return results, counts


def _cut_off_line(results: Sequence[JobResult]) -> list[str]:
    """The summary's line naming the packages a dependency's rebuild did not reach (early
    cutoff: what they build from is unchanged)."""
    cut = [r.package for r in results if r.outcome is Outcome.UP_TO_DATE and r.message]
    if not cut:
        return []
    return [f"{plural(len(cut), 'package')} cut off (a dependency was rebuilt, nothing they "
            f"build from changed): {' '.join(cut)}"]


def _settle_up_to_date(plan: BuildPlan, session: Session, emit: Emit) -> dict[str, JobResult]:
    """Up-to-date packages need no worker: their results, and one line each in a shared log
    file (a no-op build of many packages creates no directories)."""
    assert session.run_log is not None
    results: dict[str, JobResult] = {}
    lines = []
    for planned in plan.packages:
        if planned.decision is Decision.UP_TO_DATE:
            emit(JobStarted(planned.name))
            result = JobResult(planned.name, Outcome.UP_TO_DATE, message=planned.note)
            if planned.cut_off is not None:  # its record with its dependencies' new keys
                write_record(session.workspace.build_base / planned.name, planned.cut_off)
            emit(JobFinished(result))
            results[planned.name] = result
            lines.append(f"{planned.name}: up to date, "
                         f"{planned.note or 'nothing changed since the last build'}\n")
    if lines:
        with open(session.run_log / "up_to_date.log", "a") as handle:
            handle.writelines(lines)
    return results


def _run_packages(plan: BuildPlan, selection: Selection, request: BuildRequest,
                  session: Session, compilers: CompilerCache | None,
                  distribution: Distribution | None, run: PackageRun,
                  emit: Emit, shard: ShardPlan | None) -> list[JobResult]:
    """The packages to restore or build, on the scheduler's workers in the plan's start order
    (`BuildPlan.jobs_to_do`, the ready queue the plan ordered them by)."""
    jobs = plan.jobs_to_do()
    if not jobs.order:
        return []
    from wsbuild.builder.execute import execute  # lazy: off the full no-op build
    from wsbuild.builder.job import RunResources  # lazy: off the full no-op build

    assert session.run_log is not None
    options = plan.options
    if compilers is not None:
        options = replace(options, compiler_launcher=compilers.launcher)
    elif distribution is not None:
        options = replace(options, compiler_launcher=distribution.launcher)
    if distribution is not None:  # the budget knows the hosts (builder/resources/distcc.py)
        options = replace(options, jobs=distribution.budget)
    jobserver = session.jobserver(options.jobs)
    if distribution is not None:
        distribution.watch(jobserver)
    from wsbuild.builder.resources.memory import open_governor  # lazy: off `test`

    restoring = [p.name for p in plan.to_do() if p.decision is Decision.RESTORE]
    run.memory = open_governor(request.memory, restoring, selection.workspace.build_base,
                               jobserver, warn=lambda text: emit(Notice(text, warning=True)),
                               shared=shard.memory if shard is not None else None,
                               workers=request.run.workers)
    resources = RunResources(
        selection=selection, session=session, options=options, run_log=session.run_log,
        jobserver=jobserver, compilers=compilers, emit=run.timed(emit),
        unresolved=plan.unresolved, order=tuple(selection.graph.topological_order()),
        distribution=distribution, strict_dependencies=request.strict_dependencies,
        memory_gate=run.memory.wait_for_step if run.memory is not None else None)
    policy = FailurePolicy.SKIP_DEPENDENTS if request.run.continue_on_error \
        else FailurePolicy.STOP
    planned = {p.name: p for p in plan.to_do()}
    job: Callable[[str], JobResult] = lambda name: execute(planned[name], resources)
    waiting: frozenset[str] = frozenset()
    if shard is not None:  # other shards' packages are waited for (builder/shards/run.py)
        from wsbuild.builder.shards.run import shard_jobs  # lazy: off the full no-op build

        job, waiting = shard_jobs(shard, planned,
                                  lambda p: execute(p, resources), session,
                                  resources.emit, run.started)
    return run.run(jobs, job, workers=request.run.workers, policy=policy, emit=emit,
                   weights=plan.weights, waiting=waiting)


def _open_distribution(request: BuildRequest, session: Session,
                       emit: Emit) -> Distribution | None:
    """distcc for the run when --distribute asks for it and a host answers (else one warning)."""
    if request.distribute is None:
        return None
    from wsbuild.builder.resources.distcc import open_distribution  # lazy: off `test`

    assert session.run_log is not None
    return open_distribution(request.distribute, session.environ, cores=request.build.jobs,
                             run_log=session.run_log, build_base=session.workspace.build_base,
                             warn=lambda text: emit(Notice(text, warning=True)))


def _after_packages(session: Session, compilers: CompilerCache | None,
                    distribution: Distribution | None, build_types: Sequence[BuildType]
                    ) -> None:
    from wsbuild.prefix.stage import recover_all  # lazy: off `build --dry-run` and `test`

    for build_type in build_types:  # the Python types' warm setup.py helpers
        build_type.close_run()
    if compilers is not None:
        compilers.close()
    if distribution is not None:
        distribution.close()
    # a previous install parked by an unfinished direct_install goes back, never away
    recover_all(session.workspace.install_base)


def _warn(plan: BuildPlan, emit: Emit, selection: Selection, session: Session) -> None:
    """The plan's warnings, once for the run: unresolved build dependencies, overrides."""
    if plan.unresolved:
        from wsbuild.builder.failure import (
            known_names)  # lazy: off `build --dry-run`, `test` and a build resolving all

        emit(Notice(unresolved_warning(plan.unresolved, known_names(selection, session),
                                       pip_underlay=session.underlay.venv is not None),
                    warning=True))
    if plan.overrides:
        emit(Notice(override_warning(plan.overrides), warning=True))


def unresolved_warning(missing: Mapping[str, Sequence[str]], known: Collection[str] = (), *,
                       pip_underlay: bool = False) -> str:
    """The warning block: each package, each of its unresolved dependencies, the likely fix
    (`known`: the names a misspelt one may have meant)."""
    from wsbuild.underlay.wheels import install_hint  # lazy: off the full no-op build

    lines = [("build dependencies not found in the workspace, an underlay's ament index, "
              "CMAKE_PREFIX_PATH, the Python distributions, PATH or pkg-config (building "
              "anyway; --strict-dependencies refuses):")]
    for name, deps in missing.items():
        lines.append(f"  {name}:")
        lines += [f"    {dep}: {install_hint(dep, known=known, pip_underlay=pip_underlay)}"
                  for dep in deps]
    return "\n".join(lines)


def _by_name(results: Sequence[JobResult]) -> dict[str, JobResult]:
    return {r.package: r for r in results}


def _in_selection_order(selection: Selection, results: Mapping[str, JobResult]
                        ) -> list[JobResult]:
    return [results[name] for name in selection.selected if name in results]


def _stop_compilers(compilers: CompilerCache | None, distribution: Distribution | None,
                    emit: Emit) -> CompileCounts:
    """The run's compiler cache counts (then its server stops: its CPU time joins the run's),
    and where distributed compiles ran; one warning when some could not be distributed."""
    cache = None
    tool = compilers.tool if compilers is not None else ""
    if compilers is not None:
        cache = compilers.counts()
        compilers.close()
    if distribution is None:
        return CompileCounts(cache, tool=tool)
    distribution.stop_watching()
    jobs = distribution.compile_jobs()
    if jobs.fell_back:
        lost = f" ({', '.join(jobs.lost)} failed: its slots left the job budget)" \
            if jobs.lost else ""
        emit(Notice(f"distcc: {jobs.fell_back} compile job(s) could not be distributed and "
                    f"ran locally{lost}; see {distribution.log}", warning=True))
    return CompileCounts(cache, jobs, distribution.budget, tool=tool)


def _compiler_choice_text(request: BuildRequest, results: Sequence[JobResult],
                          counts: CompileCounts) -> str:
    """What the report says of the compiler cache when it has no counts: none was found, or
    nothing was built, or what was built compiled nothing."""
    choice = request.compiler_cache
    if not any(r.outcome is Outcome.FINISHED for r in results):
        return f"{choice} (nothing built)"
    if choice == "none":
        return "none (--compiler-cache none)"
    if not counts.tool:
        return f"{choice}: none used (neither ccache nor sccache is on PATH)"
    return f"{counts.tool} (nothing compiled)"


def _finish(run: PackageRun, request: BuildRequest, session: Session,
            results: Sequence[JobResult], counts: CompileCounts,
            plan: BuildPlan) -> tuple[str, ...]:
    """After the run: timings and the report into the log (runreport/package_run.py),
    durations and memory recorded for the next run; the summary's lines: packages cut off,
    the compiler cache's counts, the memory budget and peaks, with --timings the table and
    the report's path."""
    from wsbuild.builder.resources.memory import finish_memory  # lazy: off `test`

    lines = _cut_off_line(results)
    compiler = None
    cache = counts.cache
    if cache is not None:
        compiler = {"tool": cache.tool, "hits": cache.hits, "misses": cache.misses,
                    "uncacheable": cache.uncacheable, "summary": cache.summary()}
        if cache.hits + cache.misses + cache.uncacheable:
            lines.append(cache.summary())
    facts = RunFacts(verb="build", cores=request.build.jobs, workers=request.run.workers,
                     compiler_cache_choice=_compiler_choice_text(request, results, counts),
                     compiler=compiler,
                     cache=request.cache, symlink_install=request.build.symlink_install,
                     report=request.report, timings=request.timings)
    memory = finish_memory(run.memory, session.workspace.build_base, results,
                           [p.name for p in plan.to_do() if p.decision is Decision.BUILD])
    if memory is not None:
        lines += memory.summary()
    end = run.finish(results, facts, compile_jobs=counts.jobs, job_budget=counts.budget,
                     memory=memory)
    # a restore's seconds say nothing of a build's: the next estimate would be far too short
    record_durations(session.workspace.build_base,
                     [r for r in results if not r.restored],
                     memory.in_steps if memory is not None else None)
    if request.timings:
        lines += [*end.timings.table(), end.timings.summary_line()]
        if counts.jobs is not None:
            lines.append(counts.jobs.summary())
    if isinstance(end.report, str):
        lines.append(end.report)
    elif request.timings and end.report is not None:
        lines.append(f"report: {end.report}")
    return tuple(lines)
