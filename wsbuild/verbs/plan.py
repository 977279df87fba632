"""`wsbuild plan --shards N`: how a build of the selected packages splits across the N jobs of
a CI matrix (builder/shards/split.py), as text or as the matrix JSON a CI system takes."""

from __future__ import annotations

import argparse
import json
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

from wsbuild.errors import WsbuildError
from wsbuild.reporter import print_notes, print_warnings
from wsbuild.words import plural

if TYPE_CHECKING:  # imported when the verb runs, not to parse
    from wsbuild.builder.shards.split import Split
    from wsbuild.cache.settings import CacheSettings
    from wsbuild.verbs.load import LoadRequest

PLAN_DOC = """Split a build across the jobs of a CI matrix.

Prints which packages each of N jobs builds with `wsbuild build --shard K/N` and when it is
predicted to be done, balanced on the packages' recorded build times (the cache server's,
when there is one; else this workspace's last build; an estimate from its files for a
package never built). With --json, the matrix for the CI system. See docs/ci.md.

examples:
  wsbuild plan --shards 3
  wsbuild plan --shards 4 --json --cache http://cache.example:8080/

exit codes: 0 printed, 2 usage or workspace error
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of `plan` besides the workspace and package selection ones."""
    split = parser.add_argument_group("the split")
    split.add_argument("--shards", required=True, metavar="N",
                       help="the number of CI jobs to split the build across")
    split.add_argument("--parallel-workers", type=int, metavar="N",
                       help="packages each job builds at once (default: number of CPUs)")
    split.add_argument("--json", action="store_true",
                       help="the matrix as JSON (GitHub Actions' matrix.include)")
    split.add_argument("--cache", metavar="URL",
                       help="the cache server whose recorded times count "
                            "(default: $WSBUILD_CACHE)")


@dataclass(frozen=True, slots=True)
class PlanVerbRequest:
    """What `wsbuild plan` was asked: made of the command line once, at the verb's entry."""

    load: LoadRequest
    shards: int
    workers: int
    json: bool
    cache: CacheSettings | None


def plan_verb_request_from_args(args: argparse.Namespace) -> PlanVerbRequest:
    from wsbuild.builder.request import cpu_count  # lazy: off Tab completion and `--help`
    from wsbuild.builder.shards.split import parse_shard_count  # lazy: off Tab completion
    from wsbuild.cache.settings import settings_from_environment  # lazy: off Tab completion
    from wsbuild.verbs.load import load_request_from_args  # lazy: off Tab completion and `--help`

    workers = args.parallel_workers if args.parallel_workers is not None else cpu_count()
    if workers < 1:
        raise WsbuildError(f"--parallel-workers must be at least 1, got {workers}")
    settings = settings_from_environment(os.environ, url=args.cache)
    return PlanVerbRequest(load=load_request_from_args(args),
                           shards=parse_shard_count(args.shards), workers=workers,
                           json=args.json, cache=settings if settings.enabled else None)


def run_plan_verb(args: argparse.Namespace) -> int:
    """Print how the build splits across the jobs of a CI matrix."""
    from wsbuild.builder.shards.cover import run_of  # lazy: off Tab completion and `--help`
    from wsbuild.builder.shards.run import split_of  # lazy: off Tab completion and `--help`
    from wsbuild.builder.shards.split import shard_run_id  # lazy: off Tab completion and `--help`
    from wsbuild.cache.documents import SharedDocuments  # lazy: off Tab completion and `--help`
    from wsbuild.verbs.load import load  # lazy: off Tab completion and `--help`
    from wsbuild.workspace.selection import Selection  # lazy: off Tab completion and `--help`

    verb = plan_verb_request_from_args(args)
    loaded = load(verb.load, warn=print_warnings)
    if loaded.chosen_because:
        print_notes([loaded.chosen_because])
    selection = Selection(loaded.workspace, loaded.packages, loaded.graph, loaded.selected)
    documents = SharedDocuments.open(verb.cache)
    try:
        # the times the jobs of this run split on (fixed for it when one of them started)
        run = run_of(selection, shard_run_id(os.environ)) if documents is not None else ""
        split = split_of(selection, verb.shards, verb.workers, documents, run)
        problems = list(documents.problems) if documents is not None else []
    finally:
        if documents is not None:
            documents.close()
    print_warnings([f"cache: {problem}" for problem in problems])
    if verb.json:
        print(json.dumps(split.matrix(), indent=2))
    else:
        print("\n".join(plan_lines(split)))
    return 0


def plan_lines(split: Split) -> list[str]:
    """The split as text: each shard's packages and predicted time, then the figures."""
    count = len(split.assignment)
    known = count - len(split.estimated)
    lines = [f"{plural(count, 'package')} in {plural(split.count, 'shard')} of "
             f"{plural(split.workers, 'worker')} (recorded times of {known}, estimated "
             f"{len(split.estimated)})"]
    for index in range(1, split.count + 1):
        names = split.packages(index)
        lines.append(f"shard {index}/{split.count}: {plural(len(names), 'package')}, "
                     f"predicted {split.shard_seconds(index):.1f} s: {' '.join(names)}")
    lines.append(f"predicted: {split.predicted:.1f} s for the slowest shard; one job building "
                 f"everything {split.one_machine:.1f} s; no split can beat "
                 f"{split.bound:.1f} s (critical path {split.critical_seconds:.1f} s, all the "
                 f"work ÷ {split.count * split.workers} workers "
                 f"{split.total / (split.count * split.workers):.1f} s)")
    return lines
