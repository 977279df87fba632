"""One package built, one method per phase: stage → run the plan's steps, observed
(builder/observing.py), with the times make and Ninja need (builder/times.py) → register →
commit into install/ → write its record → store into the build cache. (Restored or cut off
instead: builder/reuse.py; which one, builder/execute.py.) Each package build runs in its own
worker thread and shares only read-only run resources with the others (builder/job.py)."""

from __future__ import annotations

import contextlib
import os
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from wsbuild.build_types import (
    PackageContext,
    Problems,
    Step,
    StepFailed,
    get_build_type,
)
from wsbuild.builder.context import RUN_JOBSERVER, make_context
from wsbuild.observe.steps import StepObservations
from wsbuild.builder.observing import not_inputs, observations_of, reproducible
from wsbuild.builder.oracles.step_trace import StepTraces
from wsbuild.builder.bookkeeping import (
    ADVANCE_TIMES, COMMIT, REGISTER, START_COMPILER_CACHE, BuilderStep)
from wsbuild.builder.job import PackageJob
from wsbuild.builder.plan import BUILDING_MARKER, FAILED_MARK
from wsbuild.builder.failure import exit_text, failed_result, interesting
from wsbuild.builder.resources.compiler_cache import COMPILER_VARIABLES
from wsbuild.builder.records import built_record
from wsbuild.engine.jobs import JobResult, Outcome, StepStarted
from wsbuild.engine.process import env_delta, format_command, run_command
from wsbuild.errors import WsbuildError
from wsbuild.events import Notice
from wsbuild.prefix import register_package_files, write_package_environment
from wsbuild.prefix import stage as staging
from wsbuild.record.installed import Installed
from wsbuild.record.model import PackageRecord, write_record
from wsbuild.record.observed import Where
from wsbuild.record.undeclared import installs_read, undeclared_lines
from wsbuild.workspace.model import DepCategory

@dataclass(slots=True)
class PackageBuild(PackageJob):
    """The package built: a fresh stage, the plan's steps run into it (observed), the
    package's own files registered, the stage committed into install/, its record written
    and the install stored into the build cache."""

    stage_prefix: Path | None = None
    context: PackageContext | None = None
    warnings: list[str] = field(default_factory=list)
    #: the step running now, and the suite's build-step oracle (off: traces nothing)
    step: str = ""
    traces: StepTraces = field(default_factory=StepTraces)
    #: what the steps of this build were observed to read (made by `stage`)
    observations: StepObservations | None = None
    #: why the build system still had work right after the steps ("": it had none)
    volatile: str = ""
    #: this build reuses what the last one left in the build directory (builder/records.py)
    _kept_earlier_work: bool = False
    #: files outside the package whose time this build set forward, with their content's
    #: digest then (not changed since: what the steps read, however new their times)
    touched: dict[str, str] = field(default_factory=dict)
    #: what the commit installed
    installed: list[Installed] = field(default_factory=list)

    def build(self) -> JobResult:
        """Stage; the plan's steps: the builder's before the build type's (the compiler
        cache's server, the times), the build type's, the builder's after them (register,
        commit); then write the record and store."""
        self.stage()
        try:
            for work in self.planned.before:
                self.bookkeep(work)
            self.run_steps()
            self.volatile = self._work_left()
            for work in self.planned.after:
                self.bookkeep(work)
            installed = self.installed
        except StepFailed as failure:
            self.discard()
            self._mark_failed()
            return self._failed(failure)
        except BaseException:
            self.discard()
            raise
        record = self.write_record(installed)
        self.traces.check(self.name, record, self.planned.source_dir,
                          outputs=(self.build_dir, self.prefix, self._ctx().stage_prefix),
                          exempt=self._not_inputs())
        undeclared = undeclared_lines(self.name, self._installs_read(record),
                                      self.run.selection.graph.build_closure(self.name))
        if undeclared and self.run.strict_dependencies:
            return JobResult(self.name, Outcome.FAILED, self._seconds(), log_dir=self.log_dir,
                             message="\n".join(undeclared) + "\n  (--strict-dependencies)")
        self.warnings.extend(undeclared)
        self.store(record)
        reason = self.planned.reason.text if self.planned.reason else ""
        return JobResult(self.name, Outcome.FINISHED, self._seconds(), log_dir=self.log_dir,
                         message=reason, warnings=tuple(interesting(self.warnings)))

    # ------------------------------------------------------------------------------ phases

    def stage(self) -> None:
        """Mark the build unfinished, make a fresh stage and the package's context (the one
        the plan decided its steps from, with the run's own resources: builder/context.py)."""
        from wsbuild.builder.times import redo_for_backdated  # lazy: off builds that only restore

        self.mark_unfinished()
        self.stage_prefix = staging.new_stage(self.run.selection.workspace.install_base,
                                              self.name)
        run_environ = {"MAKEFLAGS": self.run.jobserver.makeflags}
        if self.run.compilers is not None:
            run_environ.update(self.run.compilers.environ)
            run_environ.update(self.run.compilers.package_environ(self.name))
        if self.run.distribution is not None:
            run_environ.update(self.run.distribution.environ)
        self.observations = self._observations(run_environ)
        reason = self.planned.reason
        build_type = get_build_type(self.planned.build_type)
        self.context = make_context(
            self.run.selection, self.run.session, self.name, prefix=self.prefix,
            options=self.planned.options.applied_to(self.run.options),
            stage_prefix=self.stage_prefix, run_environ=run_environ, run=self._run_command,
            warn=self.warnings.append,
            redo=(*(reason.redo if reason is not None else ()), *redo_for_backdated(
                self.planned, self.build_dir, self.run.selection.workspace.root,
                self.run.session.digests, self._log)),
            observe=self.observations)
        self.context.note = self._note
        # decided before the steps run (they change what the build directory holds)
        self._kept_earlier_work = build_type.keeps_earlier_work(self.context)

    def _observations(self, run_environ: Mapping[str, str]) -> StepObservations:
        """A fresh record of what this build's steps read (builder/observing.py)."""
        return observations_of(self.run, self.build_dir, self.traces, run_environ)

    def _not_inputs(self) -> tuple[Path, ...]:
        """What the build-step oracle does not hold to the record (builder/observing.py)."""
        return not_inputs(self.run)

    def _work_left(self) -> str:
        """What the build system would still do right after the steps (its build type's
        `work_left`; "" when nothing, or when the type cannot tell)."""
        return get_build_type(self.planned.build_type).work_left(self._ctx())

    def steps(self) -> Sequence[Step]:
        """The steps the plan decided, when the build type decides the same with the build's
        context: every field of every step (label, command with its arguments, directory and
        environment, in-process action, what it reads and writes). Where the run is not what
        the plan took it to be (a dependency built in this run changed what the package's
        environment holds, no distcc host answered, the compiler cache could not start), the
        build type's answer now is run, and the package's log says what differs."""
        ctx = self._ctx()
        now = tuple(get_build_type(ctx.package.build_type).steps(ctx))
        planned = tuple(self.planned.steps)
        if now == planned:
            return planned
        self._log("The steps differ from the plan's (what the package's build sees changed "
                  "since): " + "; ".join(step_differences(planned, now))
                  + ". Running " + ", ".join(step.label for step in now))
        return now

    def bookkeep(self, work: BuilderStep) -> None:
        """One of the builder's own steps (builder/bookkeeping.py), announced as a build
        type's step is."""
        self.run.emit(StepStarted(self.name, work.label))
        if work == START_COMPILER_CACHE:
            self._start_compiler_cache()
        elif work == ADVANCE_TIMES:
            self._advance_changed_files()
        elif work == REGISTER:
            self.register()
        elif work == COMMIT:
            self.installed = self.commit()
        else:
            raise AssertionError(f"no builder step {work.label!r}")

    def _start_compiler_cache(self) -> None:
        """The run's compiler cache's server (none when the run could not open the cache)."""
        if self.run.compilers is not None:
            try:
                self.run.compilers.start()
            except WsbuildError as exc:
                raise StepFailed(f"{exc}") from None

    def run_steps(self) -> None:
        """The build type's labelled steps, into the stage: commands run as processes, the
        rest in wsbuild's own process."""
        ctx = self._ctx()
        # the steps name the run's jobserver FIFO by a placeholder, as the plan decided them
        fifo = str(self.run.jobserver.fifo)
        for step in self.steps():
            self.step = step.label
            if step.command is not None and self.run.memory_gate is not None:
                self.run.memory_gate(self.name, step.label, self.run.emit)
            self.run.emit(StepStarted(self.name, step.label))
            if step.command is not None:
                command = step.command
                run_env = {k: v.replace(str(RUN_JOBSERVER), fifo)
                           for k, v in command.run_env.items()}
                self._run_command(command.argv, cwd=command.cwd,
                                  env={**ctx.environ, **command.env, **run_env},
                                  problems=command.problems,
                                  shown_env={**ctx.environ, **command.env},
                                  run_only=tuple(run_env))
            else:
                self._run_action(step, ctx)

    def _run_action(self, step: Step, ctx: PackageContext) -> None:
        """An in-process step; when it fails without a command of its own, its by-hand
        command is what reproduces the failure."""
        assert step.action is not None
        try:
            step.action(ctx)
        except StepFailed as failure:
            if failure.command or step.by_hand is None:
                raise
            by_hand = step.by_hand
            delta = reproducible(self.run, env_delta({**ctx.environ, **by_hand.env}, os.environ))
            raise StepFailed(str(failure), command=by_hand.argv, cwd=by_hand.cwd,
                             env_delta=delta) from None

    def _advance_changed_files(self) -> None:
        """Files whose content changed while their time did not advance get the current time
        (builder/times.py), so make and Ninja see what the record sees."""
        from wsbuild.builder.times import (
            advance_changed_files)  # lazy: off builds that only restore

        self.touched.update(advance_changed_files(
            self.planned, self.build_dir, self.run.selection.workspace.root,
            self.run.session.digests, self._log))

    def register(self) -> None:
        """package.xml, the index marker and the environment hooks, into the stage."""
        from wsbuild.build_types.pybuild.paths import (
            site_packages_relpath)  # lazy: off builds that only restore

        ctx = self._ctx()
        assert self.stage_prefix is not None
        register_package_files(self.stage_prefix, self.name, ctx.package.manifest)
        run_deps = sorted(self.run.selection.graph.edges[self.name][DepCategory.RUN])
        write_package_environment(self.stage_prefix, self.name, run_deps,
                                  hooks=get_build_type(ctx.package.build_type).hooks,
                                  python_site=str(site_packages_relpath()),
                                  install_prefix=self.prefix)

    def commit(self) -> list[Installed]:
        """The stage replaces the package's prefix; returns the installed files."""
        assert self.stage_prefix is not None
        install_base = self.run.selection.workspace.install_base
        record = self.merged_record
        if record is not None:
            staging.commit_merged(self.stage_prefix, self.prefix, record,
                                  self._ctx().outputs.installed_in_place)
            return staging.installed_files(install_base, self.prefix,
                                           record.read_text().splitlines())
        staging.commit_isolated(self.stage_prefix, self.prefix)
        return staging.installed_files(install_base, self.prefix)

    def write_record(self, installed: list[Installed]) -> PackageRecord:
        """What this build's steps were observed to read, for the next run's plan
        (builder/records.py); the build is finished."""
        # its build directory and what it installs are its outputs (in a merged install the
        # prefix is every package's: only the stage is its own)
        ctx = self._ctx()
        session = self.run.session
        outputs = (self.build_dir.absolute(), ctx.stage_prefix,
                   *(() if session.merged else (self.prefix,)))
        compilers = self.run.compilers
        where = Where(source_dir=str(self.planned.source_dir.absolute()),
                      outputs=tuple(str(o) for o in outputs),
                      tool_state=tuple(str(d) for d in compilers.state_dirs())
                      if compilers is not None else ())
        build_type = get_build_type(self.planned.build_type)
        runner = build_type.test_runner
        assert self.observations is not None
        record = built_record(
            self.planned, observations=self.observations,
            earlier=self.planned.previous if self._kept_earlier_work
            else None,
            afresh=build_type.steps_run_afresh(ctx),
            declared=build_type.outside_reads(ctx), dependencies=self.dependency_keys(),
            installed=installed, where=where, touched=self.touched,
            install_base=self.run.selection.workspace.install_base,
            environment=session.environment,
            digests=session.digests, started_ns=self.started_ns, volatile=self.volatile,
            compiler_variables=COMPILER_VARIABLES
            if compilers is not None and compilers.compiles_unobserved else (),
            test_tree=runner is not None and getattr(runner, "tests_in_build_tree",
                                                     lambda _: False)(self.build_dir))
        record = replace(record, installs_read=tuple(sorted(self._installs_read(record))))
        write_record(self.build_dir, record)
        (self.build_dir / BUILDING_MARKER).unlink(missing_ok=True)
        return record

    def _installs_read(self, record: PackageRecord) -> dict[str, str]:
        """The workspace packages whose install the record's steps read (but its own)."""
        selection = self.run.selection
        return installs_read(record, selection.workspace.install_base, selection.packages,
                             merged=self.run.session.merged, but=self.name)

    def store(self, record: PackageRecord) -> None:
        """Into the build cache (when on) with its record, for the next machine or branch that
        needs it."""
        if self.planned.cache_key is None:
            return
        not_stored = self.run.session.cache.store(self.planned.cache_key, self.prefix,
                                                  self.merged_record, record)
        if not_stored:
            self._log(f"Build cache: {not_stored}")

    def discard(self) -> None:
        """After a failure: the stage goes; an install parked by an install step goes back."""
        if self.stage_prefix is not None:
            staging.recover_direct_install(self.prefix, self.stage_prefix)
            staging.discard_stage(self.stage_prefix)

    # ----------------------------------------------------------------------------- helpers

    def _note(self, text: str) -> None:
        """Information a step gives (not a warning): in command.log, and one plain line."""
        self._log(text)
        self.run.emit(Notice(text, package=self.name))

    def _mark_failed(self) -> None:
        """The unfinished build failed (rather than being cut short): the next plan says so."""
        with contextlib.suppress(OSError):
            (self.build_dir / BUILDING_MARKER).write_text(FAILED_MARK)

    def _ctx(self) -> PackageContext:
        assert self.context is not None, "stage() makes the build context"
        return self.context

    def _run_command(self, command: Sequence[str], *, cwd: Path,
                     env: Mapping[str, str] | None = None, problems: Problems | None = None,
                     shown_env: Mapping[str, str] | None = None,
                     run_only: Sequence[str] = ()) -> None:
        """A step's command, observed: logged with what reproduces it in a fresh shell, its
        stderr kept as warnings (only the `problems` among them when the build type says
        which). `shown_env` is `env` without what only this run has (a stage's DESTDIR, a
        FIFO: `run_only` names them)."""
        use_env = dict(env) if env is not None else self._ctx().environ
        delta = reproducible(self.run, env_delta(shown_env if shown_env is not None else use_env,
                                                 os.environ))
        self._log(f"Invoking command in '{cwd}': {format_command(command, cwd, delta)}")
        run_only = {k: v for k, v in env_delta(use_env, os.environ).items() if delta.get(k) != v}
        if run_only:
            self._log("  and, for this run only: " + " ".join(
                f"{k}={shlex.quote(v)}" for k, v in run_only.items()))
        assert self.observations is not None
        token, observed_env = self.observations.begin(self.step or "step", use_env, run_only)
        traced, observed_env = self.traces.command(command, self.step, self.build_dir,
                                                   observed_env)
        try:
            completed = run_command(traced, cwd=cwd, env=observed_env, log_dir=self.log_dir,
                                    pass_fds=self.run.jobserver.fds)
        finally:
            self.observations.finish(token)
        stderr = list(completed.stderr)
        if problems is not None:
            stderr = problems(stderr)
        self.warnings.extend(line for line in stderr if line.strip())
        if completed.returncode != 0:
            raise StepFailed(
                exit_text(command[0], completed.returncode, completed.tail),
                command=command, cwd=cwd, env_delta=delta, returncode=completed.returncode,
            )

    def _failed(self, failure: StepFailed) -> JobResult:
        return failed_result(self.name, failure, self.build_dir, self.log_dir, self._seconds())


def step_differences(planned: Sequence[Step], now: Sequence[Step]) -> list[str]:
    """What differs between two decisions of a package's steps, in a few words each."""
    if [step.label for step in planned] != [step.label for step in now]:
        return [f"the plan's steps were {', '.join(step.label for step in planned) or 'none'}"]
    differences = []
    for old, new in zip(planned, now):
        fields = [name for name in ("action", "command", "description", "by_hand", "reads",
                                    "writes", "why") if getattr(old, name) != getattr(new, name)]
        if old.command is not None and new.command is not None and "command" in fields:
            fields[fields.index("command")] = "command's " + ", ".join(
                name for name in ("argv", "cwd", "env", "run_env", "problems")
                if getattr(old.command, name) != getattr(new.command, name))
        if fields:
            differences.append(f"{old.label}: {', '.join(fields)}")
    return differences
