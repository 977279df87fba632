"""colcon-cache's package selection options (`--packages-select-cache-invalid`,
`--packages-skip-cache-valid`, `--packages-select-cache-key KEY`), mapped onto wsbuild's own
fingerprints: a package's `build` cache is valid when the plan of `wsbuild build`
(builder/plan.py) finds it up to date; its `test` cache when, besides, `wsbuild test` would
reuse its last passing result now (testing/cached_result.py: nothing its tests can observe
changed, judged with `test`'s own options). colcon-cache's lockfiles (`colcon cache lock`) are
not read.

`build` judges with the command line's own build options; the other verbs with those of a
plain `wsbuild build` (a package built with other options counts as invalid: it is processed,
never wrongly skipped).
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from wsbuild.verbs.arguments import secondary

if TYPE_CHECKING:  # imported when the options are given, not to parse them
    from wsbuild.builder.request import BuildRequest
    from wsbuild.workspace.selection import Selection

#: the caches colcon-cache keeps a lockfile for, as --packages-select-cache-key names them
CACHE_KEYS = ("build", "test")


def add_cache_selection_arguments(group: argparse._ActionsContainer) -> None:
    """The options, as colcon-cache declares them (the first two exclude each other)."""
    choice = group.add_mutually_exclusive_group()
    secondary(choice.add_argument(
        "--packages-select-cache-invalid", action="store_true",
        help="only packages whose build (or --packages-select-cache-key) is not up to date"))
    secondary(choice.add_argument(
        "--packages-skip-cache-valid", action="store_true",
        help="leave out packages whose build (or --packages-select-cache-key) is up to date"))
    secondary(group.add_argument(
        "--packages-select-cache-key", choices=CACHE_KEYS, metavar="KEY",
        help="the cache --packages-*-cache-* judge: build or test (default: the verb's)"))


def cache_selection_given(args: argparse.Namespace) -> bool:
    return bool(getattr(args, "packages_select_cache_invalid", False)
                or getattr(args, "packages_skip_cache_valid", False))


def select_by_cache(args: argparse.Namespace, selection: Selection) -> list[str]:
    """The selected packages whose cache (build, or test) is invalid: both options select
    the same packages, since wsbuild keeps no reference lockfile that could be missing."""
    from wsbuild.builder.pipeline import plan_build
    from wsbuild.builder.plan import Decision
    from wsbuild.engine.recording import replay_recorder

    watcher = replay_recorder()
    if watcher is not None:
        # the answer depends on the whole plan, more than a record describes: no replay (a
        # later read_only() or no_op() of the verb sets an outcome again, so not drop())
        watcher.spoiled = True
    key = args.packages_select_cache_key or ("test" if args.verb == "test" else "build")
    plan = plan_build(selection, _request(args), lambda _event: None)
    valid = {p.name for p in plan.packages if p.decision is Decision.UP_TO_DATE}
    if key == "test":
        valid &= _cached_results_apply(args, selection)
    return [name for name in selection.selected if name not in valid]


def _request(args: argparse.Namespace) -> BuildRequest:
    """The build the plan judges by: the command line's for `build`, else a plain one; no
    build cache (whether a package would be restored or built, it is invalid either way)."""
    from dataclasses import replace

    if args.verb == "build":
        from wsbuild.verbs.build import request_from_args

        return replace(request_from_args(args), cache=None)
    from wsbuild.build_types import BuildOptions
    from wsbuild.builder.request import BuildRequest, RunOptions, cpu_count

    return BuildRequest(
        build=BuildOptions(jobs=cpu_count(), python_executable=sys.executable),
        run=RunOptions(workers=cpu_count(), sequential=False, continue_on_error=False,
                       wait_for_lock=True))


def _cached_results_apply(args: argparse.Namespace, selection: Selection) -> set[str]:
    """The packages whose last passing test result `wsbuild test` would reuse now (testing/
    cached_result.py), judged with the command line's test options for `test`, else a plain
    `wsbuild test`'s; a run with --no-test-cache still judges by the cached results."""
    from wsbuild.testing.runners import reusable_results
    from wsbuild.verbs.test import request_from_args

    request = request_from_args(args, selection.workspace.root)
    return reusable_results(selection, request)
