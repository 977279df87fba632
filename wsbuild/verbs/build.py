"""`wsbuild build`: its arguments, their conversion into a BuildRequest, and the run around
builder/pipeline.py (or the dry run's plan)."""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING

from wsbuild.build_types import BuildOptions, declared_options
from wsbuild.errors import WsbuildError
from wsbuild.verbs import metas
from wsbuild.verbs.arguments import (
    add_base_arguments,
    add_env_ignore_argument,
    add_scheduling_arguments,
    env_ignore_from_args,
    secondary,
    terminal_from_args,
)
from wsbuild.verbs.cache_selection import cache_selection_from_args
from wsbuild.verbs.colcon import console_from_args
from wsbuild.verbs.metas import metadata_from_args
from wsbuild.words import plural

if TYPE_CHECKING:  # the modules of the work are imported when the verb runs, not to parse
    from wsbuild.build_types import TypeOption
    from wsbuild.builder.request import BuildRequest
    from wsbuild.builder.shards.split import Assembly
    from wsbuild.builder.shards.split import ShardSpec
    from wsbuild.cache.settings import CacheSettings
    from wsbuild.reporter import Console
    from wsbuild.verbs.load import LoadRequest
    from wsbuild.verbs.metas import MetadataRequest
    from wsbuild.workspace.selection import Selection

BUILD_DOC = """Build the packages of the workspace into install/.

Packages build in dependency order, in parallel, each replacing its install only on success; then
`source install/setup.bash`. Build dependencies nothing provides are listed as a warning first.

examples:
  wsbuild build --packages-up-to my_robot_bringup --symlink-install
  wsbuild build --packages-select my_driver --cmake-args -DCMAKE_BUILD_TYPE=Release

exit codes: 0 all built, 1 a package failed, 2 usage or workspace error, 130 Ctrl-C
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of `build` besides the workspace and package selection ones."""
    where = parser.add_argument_group("where things go")
    add_base_arguments(where)
    where.add_argument("--merge-install", action="store_true",
                       help="one install prefix for all packages, not install/<pkg>")
    where.add_argument("--symlink-install", action="store_true",
                       help="symlink Python, launch, config files: edits need no rebuild")
    how = parser.add_argument_group("how (all packages share one jobserver, as many jobs as CPUs)")
    add_scheduling_arguments(how, "built")
    how.add_argument("--continue-on-error", action="store_true",
                     help="after a failure build what does not depend on it")
    how.add_argument("--strict-dependencies", action="store_true",
                     help="unresolved build dependencies refuse the build (exit 2)")
    secondary(how.add_argument("--skip-dependency-check", action="store_true",
                               help="do not look for build dependencies (no warning)"))
    how.add_argument("--install-deps", action="store_true",
                     help="first install what nothing provides (wsbuild deps install -y)")
    how.add_argument("--force", action="store_true", help="rebuild even what is up to date")
    how.add_argument("--memory-limit", metavar="SIZE",
                     help="memory for the build: 8G, 50%% (default: free memory less a margin)")
    secondary(how.add_argument("--no-memory-limit", action="store_true",
                               help="no memory budget: packages and jobs start as the CPUs "
                                    "allow"))
    add_env_ignore_argument(how)
    secondary(how.add_argument("--allow-overriding", nargs="+", default=[], metavar="PKG",
                               help="no override warning for these packages"))
    how.add_argument("--dry-run", action="store_true",
                     help="print the plan (order, why each builds, critical path) only")
    how.add_argument("--json", action="store_true", help="with --dry-run: machine-readable")
    secondary(how.add_argument("--commands", action="store_true",
                               help="with --dry-run: also the commands that build each package"))
    how.add_argument("--timings", action="store_true",
                     help="after the summary: where the time went, the report's path")
    secondary(how.add_argument("--no-report", action="store_true",
                               help="write no log/<run>/report.html (timeline, CPU use)"))
    # the compilers of CMake packages: their group is the one the cmake type's options join
    _compiler_arguments(parser.add_argument_group("CMake packages"))
    _cache_arguments(parser.add_argument_group("build cache (always local: ~/.cache/wsbuild)"))


def add_type_arguments(parser: argparse.ArgumentParser, *, plugins: bool) -> None:
    """The options the build types declare (`TypeOption`), a group for each type in the
    order they come (an option two types share is in the first one's): the built-in types',
    and (`plugins`) those of the installed third-party types, whose scan costs; the parse
    asks for them when the command line, --help or a defaults file needs them (cli.py)."""
    added: set[str] = set()
    chosen: list[TypeOption] = []
    for name, options in declared_options(plugins=plugins):
        group = None
        for option in options:
            if not option.flag or option.flag in added:
                continue
            if group is None:  # the verb's own group of that title, if it has one
                title = f"{name} packages"
                group = next((g for g in parser._action_groups
                              if (g.title or "").lower() == title), None) \
                    or parser.add_argument_group(title)
            added.add(option.flag)
            chosen.append(option)
            kind = {"switch": {"action": "store_true"},
                    "value": {"metavar": option.metavar or "VALUE"},
                    "arguments": {"action": "extend", "nargs": "*",
                                  "metavar": option.metavar or "ARG"}}[option.kind]
            try:
                action = group.add_argument(option.flag, dest=option.dest, help=option.help,
                                            **kind)  # type: ignore[arg-type]
            except argparse.ArgumentError as exc:
                raise WsbuildError(f"build type '{name}' declares {option.flag}, which "
                                   f"`wsbuild build` has already: {exc}",
                                   hint="a build type names its own options (e.g. "
                                        "--<type>-args)") from None
            if option.secondary:
                secondary(action)
    # what the verb's request takes the values of (request_from_args)
    parser.set_defaults(type_options=tuple(chosen))


def _compiler_arguments(cmake: argparse._ArgumentGroup) -> None:
    cmake.add_argument("--compiler-cache", choices=("auto", "sccache", "ccache", "none"),
                       default="auto", metavar="TOOL",
                       help="auto (ccache, else sccache), sccache, ccache or none")
    secondary(cmake.add_argument("--distribute", metavar="HOSTS", help=(
        "compile on distcc hosts too: 'box1/16 box2/16,lzo' (or $WSBUILD_DISTRIBUTE, "
        "$DISTCC_HOSTS)")))


def _cache_arguments(cache: argparse._ArgumentGroup) -> None:
    cache.add_argument("--cache", metavar="URL",
                       help="also an HTTP cache server (default: $WSBUILD_CACHE)")
    cache.add_argument("--no-cache", action="store_true",
                       help="neither restore from nor store into any cache")
    cache.add_argument("--cache-read-only", action="store_true",
                       help="restore, store nothing (untrusted builds, e.g. pull requests)")
    secondary(cache.add_argument(
        "--shard", metavar="K/N",
        help="build the K-th of N jobs' share, meeting the others in the cache (docs/ci.md)"))
    secondary(cache.add_argument(
        "--assemble", metavar="N",
        help="the job after N `--shard` jobs: restore everything, fail naming any package no "
             "shard built and tested (docs/ci.md)"))


def _split_args(values: list[str] | None) -> tuple[str, ...]:
    # `--cmake-args -DX=1 "-DY=a b"` arrives as separate argv items; a single quoted item holding
    # several arguments is split the way a shell would
    result: list[str] = []
    for value in values or []:
        if not value:
            continue
        # a generator name has spaces of its own: `-G "Unix Makefiles"`, `-G"Unix Makefiles"`
        whole = value.startswith(("-D", "-G")) or (result and result[-1] == "-G")
        if " " in value and not whole:
            import shlex  # lazy: off a command line whose arguments hold no space

            result.extend(shlex.split(value))
        else:
            result.append(value)
    return tuple(result)


def type_values_from_args(args: argparse.Namespace) -> dict[str, object]:
    """The values of the build types' options the command line (or a defaults file, a
    mixin) gives, by dest; those left out keep their defaults."""
    values: dict[str, object] = {}
    for option in getattr(args, "type_options", ()):
        value = getattr(args, option.dest, None)
        if option.kind == "arguments":
            value = _split_args(value)
        if value != option.default and value is not None:
            values[option.dest] = value
    return values


def request_from_args(args: argparse.Namespace) -> BuildRequest:
    """The BuildRequest the options of `args` ask for (checked)."""
    from wsbuild.builder.resources.distcc import distribute_spec  # lazy: off Tab completion
    from wsbuild.builder.request import (
        BuildRequest, RunOptions, cpu_count)  # lazy: off Tab completion
    from wsbuild.engine.memory_budget import parse_memory_limit  # lazy: off Tab completion

    workers = args.parallel_workers if args.parallel_workers is not None else cpu_count()
    if workers < 1:
        raise WsbuildError(f"--parallel-workers must be at least 1, got {workers}")
    sequential = args.executor == "sequential"
    return BuildRequest(
        build=BuildOptions(
            symlink_install=args.symlink_install,
            merge_install=args.merge_install,
            jobs=cpu_count(),
            python_executable=sys.executable,
        ).with_values(type_values_from_args(args)),
        run=RunOptions(
            workers=1 if sequential else workers,
            continue_on_error=args.continue_on_error,
            wait_for_lock=not args.no_wait,
        ),
        env_ignore=env_ignore_from_args(args),
        skip_dependency_check=args.skip_dependency_check,
        strict_dependencies=args.strict_dependencies,
        force=args.force,
        compiler_cache=args.compiler_cache,
        timings=args.timings,
        cache=_cache_settings_from_args(args),
        allow_overriding=tuple(args.allow_overriding or ()),
        report=not args.no_report,
        distribute=distribute_spec(args.distribute, os.environ),
        shard=_shard_from_args(args),
        assemble=_assembly_from_args(args),
        memory=parse_memory_limit(args.memory_limit, off=args.no_memory_limit),
    )


def _shard_from_args(args: argparse.Namespace) -> ShardSpec | None:
    """--shard K/N, with the CI run it belongs to (from the environment); it needs a build
    cache on a server the jobs share."""
    if args.shard is None:
        return None
    from wsbuild.builder.shards.split import (
        parse_shard, shard_run_id)  # lazy: off the full no-op build

    spec = parse_shard(args.shard, run=shard_run_id(os.environ))
    settings = _cache_settings_from_args(args)
    if settings is None or not settings.url or settings.read_only or args.symlink_install:
        raise WsbuildError(
            f"--shard {spec.label} needs a build cache on a server the jobs share, with "
            "writes and without --symlink-install",
            hint="give --cache http://cache.example:8080/ or set WSBUILD_CACHE (docs/ci.md)")
    return spec


def _assembly_from_args(args: argparse.Namespace) -> Assembly | None:
    """--assemble N, with the CI run the shards belonged to; like --shard, it needs the
    server the shards shared."""
    if getattr(args, "assemble", None) is None:
        return None
    from wsbuild.builder.shards.split import Assembly  # lazy: off the full no-op build
    from wsbuild.builder.shards.split import (
        parse_shard_count, shard_run_id)  # lazy: off the full no-op build

    count = parse_shard_count(args.assemble, option="--assemble")
    if args.shard is not None:
        raise WsbuildError("--assemble and --shard exclude each other",
                           hint="--shard K/N in each job of the matrix, --assemble N in the "
                                "job after it")
    settings = _cache_settings_from_args(args)
    if settings is None or not settings.url:
        raise WsbuildError(
            f"--assemble {count} needs the build cache server the shards shared",
            hint="give --cache http://cache.example:8080/ or set WSBUILD_CACHE (docs/ci.md)")
    return Assembly(count, shard_run_id(os.environ))


def _cache_settings_from_args(args: argparse.Namespace) -> CacheSettings | None:
    """--cache URL / --no-cache / --cache-read-only over WSBUILD_CACHE; None when off."""
    from wsbuild.cache.settings import settings_from_environment  # lazy: off Tab completion

    settings = settings_from_environment(os.environ, url=args.cache, no_cache=args.no_cache,
                                         read_only=args.cache_read_only)
    return settings if settings.enabled else None


@dataclass(frozen=True, slots=True)
class BuildVerbRequest:
    """Everything `wsbuild build` was asked: made of the command line once, at the verb's
    entry; nothing below it sees the command line."""

    load: LoadRequest
    build: BuildRequest
    metadata: MetadataRequest
    console: Console
    #: --dry-run (--json: as JSON)
    dry_run: bool = False
    json: bool = False
    #: --dry-run --commands: the commands too
    commands: bool = False
    #: --install-deps
    install_deps: bool = False


def build_verb_request_from_args(args: argparse.Namespace) -> BuildVerbRequest:
    from wsbuild.verbs.load import load_request_from_args  # lazy: off Tab completion and `--help`

    build = request_from_args(args)
    dry_run = args.dry_run
    if args.json and not dry_run:
        raise WsbuildError("--json goes with --dry-run", hint="wsbuild build --dry-run --json")
    if args.commands and not dry_run:
        raise WsbuildError("--commands goes with --dry-run",
                           hint="wsbuild build --dry-run --commands")
    return BuildVerbRequest(
        load=load_request_from_args(args, cache=cache_selection_from_args(args, build=build)),
        build=build, metadata=metadata_from_args(args), console=console_from_args(args),
        dry_run=dry_run, json=args.json, commands=args.commands,
        install_deps=args.install_deps)


def run_build_verb(args: argparse.Namespace) -> int:
    """Build the selected packages."""
    from wsbuild.builder.pipeline import run_build  # lazy: off Tab completion and `--help`
    from wsbuild.reporter import Reporter  # lazy: off `build --help`
    from wsbuild.runreport.write import progress_of  # lazy: off Tab completion and `--help`
    from wsbuild.verbs.load import load  # lazy: off Tab completion and `--help`
    from wsbuild.workspace.selection import Selection  # lazy: off Tab completion and `--help`

    verb = build_verb_request_from_args(args)
    terminal = terminal_from_args(args)
    loaded = load(verb.load, warn=terminal.warnings, remember=not verb.dry_run, strict=True,
                  need_packages=True)
    request, notes = metas.with_build_arguments(verb.build, verb.metadata, loaded.packages,
                                                loaded.selected)
    terminal.notes(dict.fromkeys((loaded.chosen_because, *notes) if loaded.chosen_because
                                 else notes))
    selection = Selection(loaded.workspace, loaded.packages, loaded.graph, loaded.selected)
    if verb.dry_run:
        return _dry_run(selection, request, json_output=verb.json, commands=verb.commands)
    if verb.install_deps:
        from wsbuild.verbs.deps import install_for_build  # lazy: off the full no-op build

        install_for_build(loaded)
    reporter = Reporter(console=verb.console, log_base=loaded.workspace.log_base,
                        progress=progress_of(selection, request.run.workers, durations=True),
                        recorder=terminal.recorder)
    reporter.package_list([(n, loaded.packages[n].build_type) for n in loaded.selected])
    reporter.start_ticker()
    try:
        run_build(selection, request, reporter)
    finally:
        reporter.stop()
    return 0


def _dry_run(selection: Selection, request: BuildRequest, *, json_output: bool,
             commands: bool = False) -> int:
    """Print what the build would do; exit 2 when it would refuse to start."""
    import json

    from wsbuild.builder.resources.memory import (
        budget_json, budget_line)  # lazy: off Tab completion
    from wsbuild.builder.pipeline import dry_run  # lazy: off Tab completion and `--help`
    from wsbuild.builder.plan_text import plan_json, plan_lines  # lazy: off the full no-op build
    from wsbuild.reporter import Reporter  # lazy: off `build --help`

    # the plan goes to stdout (JSON for tools): a cache's warnings go to stderr
    build_plan, steps = dry_run(selection, request, Reporter(sys.stderr))
    if json_output:
        print(json.dumps({**plan_json(build_plan, steps),
                          "memory_budget": budget_json(request.memory)}, indent=2))
    else:
        print("\n".join(plan_lines(build_plan, steps if commands else None,
                                    memory=budget_line(request.memory))))
        if not commands and steps.packages:
            print(f"commands: `wsbuild build --dry-run --commands` prints those that build "
                  f"{plural(len(steps.packages), 'package')}")
    return 2 if build_plan.refusal else 0
