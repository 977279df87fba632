"""Each package's previous build and test result, for colcon-package-selection's
--packages-select-build-failed, --packages-skip-build-finished, --packages-select-test-failures
and --packages-skip-test-passed.

Read from what wsbuild records (build/<pkg>/.wsbuild/: `building` while a build runs and after
it failed or was cut short, `record.json` after it finished; the JUnit files of the last test
run), else from colcon's own records (build/<pkg>/colcon_build.rc, colcon_test.rc), so a
workspace last built by colcon works too.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from wsbuild import inputs
from wsbuild.verbs.arguments import secondary


class Previous(Enum):
    FAILED = "failed"
    FINISHED = "finished"  # built, or tested without failures
    ABORTED = "aborted"  # colcon: interrupted (not a failure)


#: colcon's result files and what it writes into them for an interrupted run
_COLCON_RESULT = "colcon_{verb}.rc"
_COLCON_SIGINT = "SIGINT"

#: the options and the verb whose results each reads
RESULT_OPTIONS = {
    "packages_select_build_failed": "build",
    "packages_skip_build_finished": "build",
    "packages_select_test_failures": "test",
    "packages_skip_test_passed": "test",
}


def previous_build(build_dir: Path) -> Previous | None:
    """The last build's result of the package whose build directory is `build_dir`."""
    from wsbuild.record.model import RECORD_FILE  # lazy: off `mixin list` and `plan --help`
    from wsbuild.builder.plan import BUILDING_MARKER  # lazy: off `list` and `graph`

    if inputs.exists(build_dir / BUILDING_MARKER):
        return Previous.FAILED
    if inputs.exists(build_dir / RECORD_FILE):
        return Previous.FINISHED
    return _colcon_result(build_dir, "build")


def previous_test(build_dir: Path) -> Previous | None:
    """The last test run's result: failed when a result file under `build_dir` has failures
    or errors, finished when there are results without any."""
    from wsbuild.testing.junit import collect_results  # lazy: off the full no-op build and `list`

    if build_dir.is_dir():
        collected = collect_results(build_dir)
        if collected.results:
            return Previous.FAILED if collected.counts.failed else Previous.FINISHED
    return _colcon_result(build_dir, "test")


def _colcon_result(build_dir: Path, verb: str) -> Previous | None:
    path = build_dir / _COLCON_RESULT.format(verb=verb)
    try:
        text = inputs.read_text(path).strip()
    except OSError:
        return None
    if text == _COLCON_SIGINT:
        return Previous.ABORTED
    return Previous.FINISHED if text == "0" else Previous.FAILED


@dataclass(frozen=True, slots=True)
class ResultSelection:
    """The one result-based selection option given: its name (a key of RESULT_OPTIONS)."""

    option: str


def add_result_selection_arguments(group: argparse._ActionsContainer) -> None:
    """colcon-package-selection's selections by the previous build or test run (one of them)."""
    group = group.add_mutually_exclusive_group()
    for option, text in (
        ("--packages-select-build-failed", "only packages whose last build failed"),
        ("--packages-skip-build-finished", "leave out packages whose last build finished"),
        ("--packages-select-test-failures", "only packages whose last tests failed"),
        ("--packages-skip-test-passed", "leave out packages whose last tests passed"),
    ):
        secondary(group.add_argument(option, action="store_true", help=text))


def result_selection_from_args(args: argparse.Namespace) -> ResultSelection | None:
    given = [dest for dest in RESULT_OPTIONS if getattr(args, dest, False)]
    return ResultSelection(given[0]) if given else None


def select_by_results(selection: ResultSelection, build_base: Path,
                      names: list[str]) -> list[str]:
    """`names` narrowed by the result-based `selection`."""
    option = selection.option
    read = previous_build if RESULT_OPTIONS[option] == "build" else previous_test
    results = {name: read(build_base / name) for name in names}
    if option.startswith("packages_select"):
        return [n for n in names if results[n] is Previous.FAILED]
    return [n for n in names if results[n] is not Previous.FINISHED]
