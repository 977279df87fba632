"""colcon-cache's package selection options (`--packages-select-cache-invalid`,
`--packages-skip-cache-valid`, `--packages-select-cache-key KEY`), mapped onto wsbuild's own
fingerprints: a package's `build` cache is valid when the plan of `wsbuild build`
(builder/plan.py) finds it up to date; its `test` cache when, besides, `wsbuild test` would
reuse its last passing result now (testing/cached_result.py: nothing its tests can observe
changed, judged with `test`'s own options). colcon-cache's lockfiles (`colcon cache lock`) are
not read.

`build` judges with the command line's own build options (`test` with its test options); the
other verbs with those of a plain `wsbuild build` (a package built with other options counts as
invalid: it is processed, never wrongly skipped); each package with its colcon.meta options
added, as the verbs add them.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING

from wsbuild import inputs
from wsbuild.verbs.arguments import secondary
from wsbuild.verbs.metas import metadata_from_args, with_build_arguments, with_test_arguments

if TYPE_CHECKING:  # imported when the options are given, not to parse them
    from wsbuild.builder.request import BuildRequest
    from wsbuild.testing.request import TestRequest
    from wsbuild.verbs.metas import MetadataRequest
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


@dataclass(frozen=True, slots=True)
class CacheSelection:
    """A cache-based selection given: which cache judges (`build` or `test`), and the requests
    it judges with (those of the verb's own command line, else a plain build's or test's)."""

    key: str
    build: BuildRequest
    test: TestRequest
    #: the colcon.meta files whose per-package options the requests get, as the verbs do
    metadata: MetadataRequest


def cache_selection_from_args(args: argparse.Namespace, *, build: BuildRequest | None = None,
                              test: TestRequest | None = None) -> CacheSelection | None:
    """The cache-based selection `args` give (None: none); `build`, `test`: the verb's own
    requests (`build` judges by its build options, `test` by its test options)."""
    if not (getattr(args, "packages_select_cache_invalid", False)
            or getattr(args, "packages_skip_cache_valid", False)):
        return None
    from wsbuild.testing.request import TestRequest  # lazy: off the full no-op build and `list`

    key = getattr(args, "packages_select_cache_key", None) or ("test" if test else "build")
    return CacheSelection(key=key, build=build or _plain_build(), test=test or TestRequest(),
                          metadata=metadata_from_args(args))


def select_by_cache(selection_by: CacheSelection, selection: Selection) -> list[str]:
    """The selected packages whose cache (build, or test) is invalid: both options select
    the same packages, since wsbuild keeps no reference lockfile that could be missing."""
    from dataclasses import replace

    from wsbuild.builder.pipeline import plan_build  # lazy: off `list` and `graph`
    from wsbuild.builder.plan import Decision  # lazy: off `list` and `graph`
    from wsbuild.testing.test_run import reusable_results  # lazy: off the full no-op build

    # the answer depends on the whole plan, more than a replay's record describes
    inputs.declare_unrecorded("a selection by the caches' validity")
    packages, selected = selection.packages, selection.selected
    # each package judged with its own options, as the verb would build or test it (the
    # verb says what colcon.meta holds that it does not apply)
    build, _ = with_build_arguments(selection_by.build, selection_by.metadata, packages, selected)
    # no build cache: whether a package would be restored or built, it is invalid either way
    plan = plan_build(selection, replace(build, cache=None), lambda _event: None)
    valid = {p.name for p in plan.packages if p.decision is Decision.UP_TO_DATE}
    if selection_by.key == "test":
        test, _ = with_test_arguments(selection_by.test, selection_by.metadata, packages,
                                      selected)
        # a run with --no-test-cache still judges by the cached results
        valid &= reusable_results(selection, test)
    return [name for name in selection.selected if name not in valid]


def _plain_build() -> BuildRequest:
    """What a plain `wsbuild build` asks for."""
    from wsbuild.build_types import BuildOptions  # lazy: off `mixin list` and `plan --help`
    from wsbuild.builder.request import BuildRequest, RunOptions, cpu_count  # lazy: off `list`

    return BuildRequest(
        build=BuildOptions(jobs=cpu_count(), python_executable=sys.executable),
        run=RunOptions(workers=cpu_count(), continue_on_error=False,
                       wait_for_lock=True))
