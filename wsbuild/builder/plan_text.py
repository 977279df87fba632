"""The plan as `build --dry-run` shows it: lines for people, JSON for tools; with each package
that would build, the commands of its steps, which pasted in order into a fresh shell in the
workspace build it."""

from __future__ import annotations

import os
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from wsbuild.build_types import Step
from wsbuild.builder.bookkeeping import BuilderStep
from wsbuild.builder.overrides import override_warning
from wsbuild.builder.plan import BuildPlan, Decision, PackagePlan
from wsbuild.engine.process import env_delta, format_command
from wsbuild.session import Session
from wsbuild.words import plural
from wsbuild.workspace.selection import Selection


@dataclass(frozen=True, slots=True)
class PlannedSteps:
    """A package's steps as the build would run them now, and the environment they start
    from (its dependencies' prefixes applied, as far as they are installed)."""

    build_dir: Path
    steps: tuple[Step, ...]
    environ: Mapping[str, str]
    #: the builder's own steps before and after the build type's (builder/bookkeeping.py)
    before: tuple[BuilderStep, ...] = ()
    after: tuple[BuilderStep, ...] = ()


@dataclass(frozen=True, slots=True)
class PlannedCommands:
    """What `--dry-run` shows of the steps: the session's environment (the ROS underlay's)
    as its difference from wsbuild's own, then each package's steps, in build order."""

    #: the variables the session's environment sets (every command starts from it)
    session_env: Mapping[str, str]
    #: the session's environment itself, which the steps' variables are told against
    session_environ: Mapping[str, str]
    packages: Mapping[str, PlannedSteps]

    def lines(self, names: Sequence[str]) -> list[str]:
        """Shell lines that, pasted in order into a shell in the workspace, build `names`:
        the session's environment exported once, then each package's lines."""
        lines = ["# the environment every command starts from (the ROS underlay's)",
                 _export_line(self.session_env)] if self.session_env else []
        for name in names:
            if name in self.packages:
                lines.append(f"# {name}")
                lines += self.package_lines(name)
        return lines

    def package_lines(self, name: str) -> list[str]:
        """A package's build directory made, then each step's command (`cd DIR && VAR=value
        … program args`, the variables it sets beyond the session's environment), an
        in-process step's by-hand command after a comment saying what wsbuild does instead;
        a step with neither, a comment."""
        planned = self.packages[name]
        lines = [f"mkdir -p -- {shlex.quote(str(planned.build_dir))}"]
        lines += [f"# (in wsbuild) {work.description} (no command)" for work in planned.before]
        for step in planned.steps:
            command = step.shown
            if step.why is not None:  # a step that runs only sometimes: why it runs now
                lines.append(f"# {step.label}: {step.why.text}")
            if step.command is None:
                # what wsbuild does in its own process, and where
                where = ", ".join(_shown_path(path) for path in step.writes)
                lines.append(f"# (in wsbuild) {step.description or step.label}"
                             + (f": {where}" if where else "")
                             + ("" if command is not None else " (no command to show)"))
            if command is not None:
                lines.append(format_command(command.argv, command.cwd,
                                            self.step_env(planned, command.env)))
        lines += [f"# (in wsbuild) {work.description} (no command)" for work in planned.after]
        return lines

    def step_env(self, planned: PlannedSteps, env: Mapping[str, str]) -> dict[str, str]:
        return env_delta({**planned.environ, **env}, self.session_environ)


def planned_commands(build_plan: BuildPlan, selection: Selection, session: Session, *,
                     compiler_cache: str = "") -> PlannedCommands:
    """The steps of every package the plan builds (a restore has none), as the plan decided
    them (builder/plan.py, from the context builder/context.py makes, with the compiler cache
    the build would choose as the compilers' launcher); the run's own resources (jobserver,
    the compiler cache's private directory, stage) are not there, so neither are they in the
    commands. Distributed compiles (`--distribute`) are not foreseen: the build probes its
    hosts first."""
    found = {planned.name: PlannedSteps(selection.workspace.build_base / planned.name,
                                        planned.steps, planned.step_environ,
                                        planned.before, planned.after)
             for planned in build_plan.to_do() if planned.decision is Decision.BUILD}
    return PlannedCommands(env_delta(session.environ, os.environ), dict(session.environ), found)


def _shown_path(path: Path) -> str:
    """A path as the dry run shows it: relative to the working directory when inside it."""
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def _export_line(env: Mapping[str, str]) -> str:
    return "export " + " ".join(f"{k}={shlex.quote(v)}" for k, v in env.items())


def _missing_scripts(commands: PlannedCommands) -> list[str]:
    """CMake initial-cache scripts (`-C FILE`) the commands name that do not exist yet: the
    build writes them before it starts (the lint stand-ins)."""
    missing: list[str] = []
    for planned in commands.packages.values():
        for step in planned.steps:
            argv = step.shown.argv if step.shown is not None else ()
            for index, arg in enumerate(argv):
                path = argv[index + 1] if arg == "-C" and index + 1 < len(argv) else \
                    arg[2:] if arg.startswith("-C") and len(arg) > 2 else ""
                if path and not Path(path).exists() and path not in missing:
                    missing.append(path)
    return missing


def plan_lines(build_plan: BuildPlan, commands: PlannedCommands | None = None,
               memory: str = "") -> list[str]:
    """The plan as a person reads it; `memory`: the line naming the memory budget
    (builder/resources/memory.py), after the critical path."""
    packages = build_plan.packages
    building = build_plan.to_do()
    lines = [f"dry run: {plural(len(packages), 'package')}, "
             f"{len(building)} would build, {len(packages) - len(building)} up to date "
             "(nothing was touched)"]
    width = max((len(p.name) for p in packages), default=0)
    digits = len(str(len(packages)))
    for number, package in enumerate(packages, start=1):
        what = _what(package)
        lines.append(f"  {number:>{digits}}. {package.name.ljust(width)}  {what}")
    if build_plan.critical_path:
        lines.append(f"critical path (about {build_plan.critical_seconds:.0f} s of the last "
                     f"recorded or estimated durations): {' → '.join(build_plan.critical_path)}")
    if memory:
        lines.append(memory)
    if build_plan.unresolved:
        lines.append("unresolved build dependencies (the build warns and goes on; "
                     "--strict-dependencies refuses):")
        lines += [f"  {name}: {', '.join(deps)}" for name, deps in build_plan.unresolved.items()]
    if build_plan.overrides:
        lines += ["warning: " + override_warning(build_plan.overrides)]
    if commands is not None and commands.packages:
        lines.append("commands (pasted in order into a shell in the workspace, they build "
                     "what would build):")
        lines += [f"  {line}" for line in commands.lines([p.name for p in packages])]
        lines += [f"note: the commands read {path}, which `wsbuild build` writes before it "
                  "builds (a dry run writes nothing)" for path in _missing_scripts(commands)]
    lines += [f"note: {text}" for text in build_plan.notices]
    if build_plan.refusal:
        lines.append(f"the build would refuse to start: {build_plan.refusal.summary}")
    return lines


def plan_json(build_plan: BuildPlan,
              commands: PlannedCommands | None = None) -> dict[str, object]:
    """The plan for tools (`--dry-run --json`); a package that would build has its `steps`
    (each step's `env`: what it sets beyond the session's environment, `environment`) and
    `commands` (its shell lines as `--dry-run` prints them)."""
    steps = {} if commands is None else commands.packages
    return {
        "packages": [
            {
                "name": p.name,
                "build_type": p.build_type,
                "up_to_date": p.decision is Decision.UP_TO_DATE,
                "decision": p.decision.value,
                "note": p.note or None,
                "wait": None if p.wait is None else {"shard": p.wait.owner,
                                                     "seconds": p.wait.seconds},
                "reason": None if p.reason is None else {
                    "kind": p.reason.kind.value, "text": p.reason.text,
                    "details": list(p.reason.details),
                    # built only if what it read of those dependencies changes (cutoff)
                    "cutoff": p.reason.cutoff,
                },
                **({} if commands is None or p.name not in steps else {
                    "steps": [*map(_builder_step_json, steps[p.name].before),
                              *(_step_json(step, commands.step_env(steps[p.name], step.shown.env)
                                           if step.shown is not None else None)
                                for step in steps[p.name].steps),
                              *map(_builder_step_json, steps[p.name].after)],
                    "commands": commands.package_lines(p.name)}),
            }
            for p in build_plan.packages
        ],
        "critical_path": {"packages": list(build_plan.critical_path),
                          "seconds": round(build_plan.critical_seconds, 3)},
        "unresolved": {name: list(deps) for name, deps in build_plan.unresolved.items()},
        "not_built": {name: list(users) for name, users in build_plan.not_built.items()},
        "overrides": [{"package": o.package, "prefix": os.fspath(o.prefix),
                       "users": list(o.users)} for o in build_plan.overrides],
        "refusal": build_plan.refusal.summary if build_plan.refusal else None,
        "notices": list(build_plan.notices),
        "environment": {} if commands is None else dict(commands.session_env),
    }


def _what(package: PackagePlan) -> str:
    if package.reason is None:
        return f"up to date: {package.note}" if package.note else "up to date"
    if package.decision is Decision.RESTORE:
        return f"restore from cache: {package.reason.text}"
    if package.wait is not None:
        return (f"wait for shard {package.wait.owner} (up to {package.wait.seconds:.0f} s), "
                f"then restore from cache, else build: {package.reason.text}")
    return f"build: {package.reason.text}"


def _step_json(step: Step, env: Mapping[str, str] | None) -> dict[str, object]:
    command = step.shown
    return {
        "label": step.label,
        "in_process": step.command is None,
        "description": step.description,
        "argv": None if command is None else list(command.argv),
        "cwd": None if command is None else os.fspath(command.cwd),
        "env": None if env is None else dict(env),
        "reads": [os.fspath(path) for path in step.reads],
        "writes": [os.fspath(path) for path in step.writes],
        "why": None if step.why is None else {"kind": step.why.kind.value,
                                               "text": step.why.text,
                                               "details": list(step.why.details)},
        "builder": False,
    }


def _builder_step_json(work: BuilderStep) -> dict[str, object]:
    """One of the builder's own steps, in the form of a build type's in-process step."""
    return {"label": work.label, "in_process": True, "description": work.description,
            "argv": None, "cwd": None, "env": None, "reads": [], "writes": [], "why": None,
            "builder": True}
