"""`wsbuild test` and `wsbuild test-result`: their arguments, the TestRequest made of them,
and the runs around testing/test_run.py and testing/junit.py."""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.build_types import get_build_type
from wsbuild.errors import Interrupted, WorkspaceError, WsbuildError
from wsbuild.events import Notice, Summary
from wsbuild.reporter import Reporter, print_notes, print_warnings
from wsbuild.verbs.arguments import (
    add_base_arguments,
    add_env_ignore_argument,
    env_ignore_from_args,
    add_scheduling_arguments,
    add_workspace_option,
    secondary,
)
from wsbuild.verbs.colcon import console_from_args
from wsbuild.workspace.root import BUILD_BASE

if TYPE_CHECKING:  # the modules of the work are imported when the verb runs, not to parse
    from wsbuild.builder.shards.split import ShardSpec
    from wsbuild.reporter import Console
    from wsbuild.workspace.selection import Selection
    from wsbuild.testing.request import TestRequest
    from wsbuild.verbs.load import Loaded, LoadRequest
    from wsbuild.verbs.metas import MetadataRequest

TEST_DOC = """Run the tests of the packages against the built workspace.

In dependency order and in parallel, as colcon does: pytest in the source directory of
Python packages, CTest in the build directory of CMake ones. JUnit results go to
build/<pkg>/test_results/<pkg>/. Unlike colcon, a failing test makes the exit code 1.
A package's last passing result is reused ("cached", with its counts and log) while
nothing its tests can observe changed: its build and those of its test dependencies, its
files, the test options, the environment variables that matter, the test tools.
--no-test-cache runs every test.

examples:
  wsbuild test --packages-select my_driver --pytest-args -k 'not slow' --
  wsbuild test --ctest-args -R gtest -- --retest-until-pass 2
  wsbuild test-result --verbose

exit codes: 0 all tests passed (or there were none), 1 a test failed or errored,
2 usage or workspace error (e.g. a package is not built), 130 Ctrl-C
"""

TEST_RESULT_DOC = """Show the results of earlier test runs; fail when a test failed.

Reads every JUnit XML file under build/ (or --test-result-base), also those colcon test
wrote, and the CTest results colcon leaves in build/<pkg>/Testing/. Prints a line for each
result file with failures or errors (--all: every file) and a summary, as colcon
test-result does; an ament test is counted once, where colcon also counts its CTest entry.

exit codes: 0 no failures or errors, 1 a test failed or errored, 2 no results directory
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of `test` besides the workspace and package selection ones."""
    where = parser.add_argument_group("where things are")
    add_base_arguments(where)
    where.add_argument("--merge-install", action="store_true",
                       help="built with --merge-install (default: what install/ holds)")
    secondary(where.add_argument(
        "--test-result-base", metavar="DIR",
        help="write JUnit results to DIR/<pkg>/, relative to the workspace "
             "(default: <build-base>/<pkg>/test_results/<pkg>/)"))
    how = parser.add_argument_group("how")
    add_scheduling_arguments(how, "tested")
    secondary(how.add_argument("--no-report", action="store_true",
                               help="write no log/<run>/report.html (timeline, CPU use)"))
    secondary(how.add_argument(
        "--require-linters", "--strict-linters", action="store_true", dest="strict_linters",
        help="a test of an ament linter, or of the program it runs, that is not installed "
             "fails (CI; default: not run, counted as skipped)"))
    how.add_argument("--build", action="store_true", dest="build_first",
                     help="first build the selected packages whose sources changed since "
                          "they were built (default: say so, and test what was built)")
    how.add_argument("--no-test-cache", action="store_true",
                     help="run every test, even where the last passing result still applies")
    how.add_argument("--dry-run", action="store_true",
                     help="say which packages' tests would run and why, and which would reuse "
                          "their last passing result; run and write nothing")
    how.add_argument("--shard", metavar="K/N",
                     help="test what `build --shard K/N` built here (docs/ci.md)")
    add_env_ignore_argument(how)
    how.add_argument("--abort-on-error", action="store_true",
                     help="start no more packages once one has failing tests")
    how.add_argument("--pytest-args", action="append", metavar="ARG",
                     help="for pytest, e.g. -k 'not slow' -x; end with --")
    how.add_argument("--ctest-args", action="append", metavar="ARG",
                     help="for ctest, e.g. -R gtest -j4; end with --")
    retest = how.add_mutually_exclusive_group()
    secondary(retest.add_argument("--retest-until-fail", type=int, default=0, metavar="N",
                                  help="run a package's tests up to N more times while they "
                                       "pass (to catch flaky tests)"))
    retest.add_argument("--retest-until-pass", type=int, default=0, metavar="N",
                        help="rerun failing tests up to N times (then: flaky)")
    secondary(how.add_argument("--return-code-on-test-failure", action="store_true",
                               help="accepted for colcon compatibility: failing tests always "
                                    "make the exit code 1"))


def add_result_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of `test-result`."""
    add_workspace_option(parser, found="found from the current directory")
    parser.add_argument("--test-result-base", metavar="DIR",
                        help="where the results are, relative to the workspace "
                             f"(default: {BUILD_BASE})")
    parser.add_argument("--all", action="store_true",
                        help="also list result files without failures or errors")
    parser.add_argument("--verbose", action="store_true",
                        help="show each failing test with its messages and output")
    parser.add_argument("--result-files-only", action="store_true",
                        help="print only the paths of the result files (with --all: every one)")


def request_from_args(args: argparse.Namespace, root: Path) -> TestRequest:
    """Validate the options of `wsbuild test`; relative paths are relative to the workspace."""
    from wsbuild.builder.request import cpu_count  # lazy: off `test-result` and Tab completion
    from wsbuild.testing.request import TestRequest  # lazy: off `test-result` and Tab completion

    workers = args.parallel_workers
    workers = cpu_count() if workers is None else workers
    if workers < 1:
        raise WsbuildError(f"--parallel-workers must be at least 1, got {workers}")
    until_fail = args.retest_until_fail or 0
    until_pass = args.retest_until_pass or 0
    for flag, value in (("--retest-until-fail", until_fail), ("--retest-until-pass", until_pass)):
        if value < 0:
            raise WsbuildError(f"{flag} must not be negative, got {value}")
    if until_fail and until_pass:
        raise WsbuildError("--retest-until-fail and --retest-until-pass exclude each other")
    base = args.test_result_base
    tools = {"pytest": _passthrough(args.pytest_args),
             "ctest": _passthrough(args.ctest_args)}
    return TestRequest(
        tool_arguments={tool: arguments for tool, arguments in tools.items() if arguments},
        retest_until_fail=until_fail,
        retest_until_pass=until_pass,
        test_result_base=(root / base).absolute() if base else None,
        merge_install=True if args.merge_install else None,
        workers=1 if args.executor == "sequential" else workers,
        abort_on_error=args.abort_on_error,
        wait_for_lock=not args.no_wait,
        python_executable=sys.executable,
        strict_linters=args.strict_linters,
        reuse_results=not args.no_test_cache,
        report=not args.no_report,
        env_ignore=env_ignore_from_args(args),
    )


def _passthrough(values: list[str] | None) -> tuple[str, ...]:
    # colcon's rule: each value is one argument, leading spaces stripped (`--pytest-args " -k"`);
    # no splitting, so `--pytest-args -k "a and b"` keeps the expression whole
    return tuple(v.lstrip() for v in values or [] if v.strip())


@dataclass(frozen=True, slots=True)
class TestVerbRequest:
    """Everything `wsbuild test` was asked: made of the command line once, at the verb's
    entry; nothing below it sees the command line."""

    __test__ = False  # not a pytest test class

    load: LoadRequest
    test: TestRequest
    metadata: MetadataRequest
    console: Console
    #: --shard K/N: this job's share of the split (builder/shards/run.py)
    shard: ShardSpec | None = None
    #: --build: build what changed since it was built first
    build_first: bool = False
    #: --dry-run: say what would run and why (testing/test_run.py: `test_plan`)
    dry_run: bool = False


def test_verb_request_from_args(args: argparse.Namespace) -> TestVerbRequest:
    from wsbuild.verbs.cache_selection import cache_selection_from_args  # lazy: off `test-result`
    from wsbuild.verbs.load import (
        load_request_from_args, workspace_root)  # lazy: off Tab completion
    from wsbuild.verbs.metas import metadata_from_args  # lazy: off `test-result`

    test = request_from_args(args, workspace_root(args.workspace_dir))
    shard = None
    if args.shard is not None:
        from wsbuild.builder.shards.split import (
            parse_shard, shard_run_id)  # lazy: off `test-result`

        shard = parse_shard(args.shard, run=shard_run_id(os.environ))
    return TestVerbRequest(
        load=load_request_from_args(args, cache=cache_selection_from_args(args, test=test)),
        test=test, metadata=metadata_from_args(args), console=console_from_args(args),
        shard=shard, build_first=args.build_first, dry_run=args.dry_run)


def run_test_verb(args: argparse.Namespace) -> int:
    """Run the tests of the selected packages; 1 when any test fails or errors."""
    from wsbuild.runreport.write import progress_of  # lazy: off `test-result` and Tab completion
    from wsbuild.testing.results import summary_lines  # lazy: off `test-result` and Tab completion
    from wsbuild.testing.test_run import run_tests  # lazy: off `test-result` and Tab completion
    from wsbuild.verbs import metas  # lazy: off `test-result`
    from wsbuild.verbs.load import load  # lazy: off Tab completion and `--help`
    from wsbuild.workspace.selection import Selection  # lazy: off Tab completion and `--help`

    verb = test_verb_request_from_args(args)
    loaded = load(verb.load, warn=print_warnings, need_packages=True)
    request, notes = metas.with_test_arguments(verb.test, verb.metadata, loaded.packages,
                                               loaded.selected)
    print_notes(dict.fromkeys((loaded.chosen_because, *notes) if loaded.chosen_because
                              else notes))
    selection = Selection(loaded.workspace, loaded.packages, loaded.graph, loaded.selected)
    shard_run = ""
    if verb.shard is not None:  # the packages `build --shard` built here
        from wsbuild.builder.shards.cover import run_of  # lazy: off `test-result` and `test`
        from wsbuild.builder.shards.run import test_selection  # lazy: off `test-result` and `test`
        from wsbuild.cache.settings import settings_from_environment  # lazy: off `test-result`

        shard_run = run_of(selection, verb.shard.run)
        selection, line = test_selection(selection, verb.shard, request.workers,
                                         settings_from_environment(os.environ))
        print_notes([line])
    if verb.dry_run:
        from wsbuild.testing.test_run import test_plan, test_plan_lines  # lazy: off `test-result`

        print("\n".join(test_plan_lines(test_plan(selection, request))))
        return 0
    console = verb.console
    reporter = Reporter(verb="test", console=console, log_base=loaded.workspace.log_base,
                        progress=progress_of(selection, request.workers, durations=False))
    reporter.package_list([(n, loaded.packages[n].build_type) for n in selection.selected])
    missing = _missing_ros_pytest(loaded, request.python_executable)
    if missing:
        reporter(Notice(missing, warning=True))
    changed = _changed_since_built(selection, verb.build_first)
    reporter.start_ticker()
    try:
        if changed:
            _build_changed(selection, changed, request, reporter)
        _build_test_trees(selection, request, reporter)
        run = run_tests(selection, request, reporter)  # timings, report: runreport/package_run.py
        if console.summary:
            reporter(Summary(tuple(summary_lines(run, shown=Path.cwd()))))
    finally:
        reporter.stop()
    if run.interrupted:
        raise Interrupted("tests interrupted")
    if verb.shard is not None:  # what this shard tested, for the assembling job
        _note_tested(verb.shard, shard_run, selection)
    return 1 if run.failed else 0


def _note_tested(shard: ShardSpec, run: str, selection: Selection) -> None:
    from wsbuild.builder.shards.cover import note_tested  # lazy: off `test-result` and `test`
    from wsbuild.cache.settings import settings_from_environment  # lazy: off `test-result`

    settings = settings_from_environment(os.environ)
    problems = note_tested(settings if settings.enabled else None, run, shard.count,
                           shard.index, selection.selected,
                           selection.workspace.build_base / ".wsbuild")
    print_warnings([f"cache: {problem}" for problem in problems])


def _changed_since_built(selection: Selection, build_first: bool) -> list[str]:
    """The selected packages whose sources changed since they were built: with --build, to
    build first; else one line each saying so (their tests run what was built)."""
    from wsbuild.builder.changed_since import sources_changed  # lazy: off `test-result`

    changed = sources_changed(selection, selection.selected)
    if build_first:
        return list(changed)
    print_warnings([f"{name} changed since it was built ({why}): its tests run what was "
                    "built; run `wsbuild build` first, or `wsbuild test --build`"
                    for name, why in changed.items()])
    return []


def _build_changed(selection: Selection, names: list[str], request: TestRequest,
                   reporter: Reporter) -> None:
    """--build: the changed packages built as they were last built (their records' options)."""
    import json

    from wsbuild.builder.pipeline import run_build  # lazy: off `test-result` and Tab completion
    from wsbuild.builder.request import (
        BuildRequest, RunOptions, options_of_record)  # lazy: off `test-result`
    from wsbuild.record.model import read_record  # lazy: off `test-result`
    from wsbuild.workspace.selection import Selection as Selected  # lazy: off Tab completion

    groups: dict[str, list[str]] = {}
    for name in names:
        record = read_record(selection.workspace.build_base / name)
        options = record.settings.get("options") if record is not None else None
        groups.setdefault(json.dumps(options or {}, sort_keys=True), []).append(name)
    for options, group in groups.items():
        reporter(Notice(f"building {' '.join(group)} first: changed since it was built "
                        "(--build)"))
        run_build(Selected(selection.workspace, selection.packages, selection.graph, group),
                  BuildRequest(build=options_of_record(json.loads(options)),
                               run=RunOptions(workers=request.workers, continue_on_error=False,
                                              wait_for_lock=request.wait_for_lock),
                               report=False), reporter)


def _build_test_trees(selection: Selection, request: TestRequest, reporter: Reporter) -> None:
    """The selected packages restored from the build cache whose tests run from their build
    directories (CTest): the cache brought back their install, not that tree, so they are
    built first (configure, build, install), with the options their records hold."""
    import json

    from wsbuild.builder.pipeline import run_build  # lazy: off `test-result` and Tab completion
    from wsbuild.builder.request import (
        BuildRequest, RunOptions, options_of_record)  # lazy: off `test-result`
    from wsbuild.record.model import read_record  # lazy: off `test-result`
    from wsbuild.workspace.selection import Selection  # lazy: off Tab completion and `--help`

    groups: dict[str, list[str]] = {}
    for name in selection.selected:
        runner = get_build_type(selection.packages[name].build_type).test_runner
        build_dir = selection.workspace.build_base / name
        record = read_record(build_dir)
        if runner is None or record is None or not record.test_tree or runner.built(build_dir):
            continue
        groups.setdefault(json.dumps(record.settings.get("options") or {}, sort_keys=True),
                          []).append(name)
    for options, names in groups.items():
        reporter(Notice(f"building {' '.join(names)} for {'its' if len(names) == 1 else 'their'}"
                        " tests first: a restore from the build cache brings back an install, "
                        "not the build directory CTest runs the tests from"))
        run_build(Selection(selection.workspace, selection.packages, selection.graph, names),
                  BuildRequest(build=options_of_record(json.loads(options)),
                               run=RunOptions(workers=request.workers,
                                              continue_on_error=False,
                                              wait_for_lock=request.wait_for_lock),
                               force=True, report=False), reporter)


def _missing_ros_pytest(loaded: Loaded, python_executable: str) -> str:
    """One line when a selected package has pytest tests and the pytest the distro's plugins
    need is not where `wsbuild test` looks ("" otherwise)."""
    from wsbuild.build_types.pybuild.tests import PYTEST  # lazy: off `test-result`
    from wsbuild.testing.pytest_env import (
        ROS_PYTEST_VERSION, install_hint)  # lazy: off `test-result`
    from wsbuild.build_types.ros_pytest import (
        ros_pytest_dir, ros_pytest_installed)  # lazy: off `test-result`

    if ros_pytest_installed(python_executable) or not any(
            get_build_type(loaded.packages[n].build_type).test_runner is PYTEST
            for n in loaded.selected):
        return ""
    return (f"pytest {ROS_PYTEST_VERSION}, which ROS 2 Jazzy's pytest plugins need, is not in "
            f"{ros_pytest_dir(python_executable)}: tests run with the venv's pytest; install it "
            f"with {install_hint(python_executable)}")


def run_test_result_verb(args: argparse.Namespace) -> int:
    """Show the results of earlier test runs (wsbuild's or colcon's); 1 when any failed."""
    from wsbuild.testing.junit import collect_results, report_lines  # lazy: off Tab completion
    from wsbuild.verbs.load import workspace_root  # lazy: off Tab completion and `--help`

    root = workspace_root(args.workspace_dir)
    base = root / (getattr(args, "test_result_base", None) or getattr(args, "build_base", None)
                   or BUILD_BASE)
    if not base.is_dir():
        raise WorkspaceError("no test results: the directory does not exist", path=base,
                             hint="run wsbuild test first, or pass --test-result-base")
    collected = collect_results(base)
    print_warnings(collected.warnings)
    if getattr(args, "delete", False) or getattr(args, "delete_yes", False):
        return _delete_results([r.path for r in collected.results], ask=not args.delete_yes)
    for line in report_lines(collected, show_all=getattr(args, "all", False),
                             verbose=getattr(args, "verbose", False),
                             files_only=getattr(args, "result_files_only", False),
                             shown=Path.cwd()):
        print(line)
    return 1 if collected.counts.failed else 0


def _delete_results(paths: list[Path], *, ask: bool) -> int:
    """colcon test-result --delete (asks first) / --delete-yes: remove the result files."""
    from wsbuild.verbs.clean import deletion_confirmed  # lazy: off `test-result` and `test`

    if not paths:
        print("no result files to delete")
        return 0
    print(f"test-result will delete {len(paths)} result file(s):")
    for path in paths:
        print(f"  {path}")
    if ask and not deletion_confirmed("--delete-yes"):
        return 0
    for path in paths:
        path.unlink(missing_ok=True)
    print(f"deleted {len(paths)} result file(s)")
    return 0
