"""`log/<run>/report.json`: what a run knows that its other log files do not say (the command
line, settings, each package's dependencies and outcome, CPU samples, test results), written
at the end of the run from data it already holds. With `timings.json`, each package's
`command.log` and the JUnit files, it is all the report page (runreport/page.py) reads.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.engine.cpu_sampler import CpuSample
from wsbuild.engine.jobs import JobResult, Outcome
from wsbuild.engine.ready_queue import JobGraph
from wsbuild.engine.timing_files import started_at
from wsbuild import __version__, inputs
from wsbuild.redaction import redact
from wsbuild.patterns import lazy

if TYPE_CHECKING:
    from wsbuild.cache.settings import CacheSettings
    from wsbuild.workspace.selection import Selection


@dataclass(frozen=True, slots=True)
class RunFacts:
    """What a run tells its report about itself (the build or the test run fills it in)."""

    #: "build" or "test"
    verb: str
    cores: int
    workers: int
    #: --compiler-cache as asked, and what the cache counted (tool, hits, misses, ...)
    compiler_cache_choice: str = ""
    compiler: Mapping[str, object] | None = None
    #: the build cache (None: off)
    cache: CacheSettings | None = None
    symlink_install: bool = False
    #: --no-report turns the report off; --timings prints its path
    report: bool = True
    timings: bool = False

#: the line of CMakeCache.txt naming the generator (as build_types/cmake.py reads it)
_GENERATOR = lazy(r"^CMAKE_GENERATOR:INTERNAL=(.*)$", re.MULTILINE)
REPORT_JSON = "report.json"
REPORT_HTML = "report.html"
FORMAT = 1


def command_line(argv: Sequence[str] | None = None) -> str:
    """The command as a user would type it again (`wsbuild build --timings`)."""
    args = sys.argv[1:] if argv is None else argv
    return redact(shlex.join(["wsbuild", *args]))


def artifact_cache_text(settings: CacheSettings | None, symlink_install: bool = False) -> str:
    if symlink_install:
        return "off (--symlink-install builds are not cached)"
    if settings is None:
        return "off"
    from wsbuild.cache.settings import redact  # lazy: off `report`

    where = "local" + (f" + {redact(settings.url)}" if settings.url else "")
    return where + (" (read-only)" if settings.read_only else "")


def path_in_log(path: Path | None, base: Path) -> str | None:
    """`path` as the report names it: relative to the run's log directory `base`."""
    if path is None:
        return None
    try:
        return os.path.relpath(path, base)
    except ValueError:
        return str(path)


def _result_fields(result: JobResult, run_log: Path) -> dict[str, object]:
    return {"outcome": result.outcome.value, "seconds": round(result.seconds, 3),
            "message": result.message, "reproduce": result.reproduce,
            "log_dir": path_in_log(result.log_dir, run_log)}


def _generator(selection: Selection, results: Iterable[JobResult]) -> str:
    """The CMake generator of the run: from the CMakeCache.txt of a CMake package, preferring
    one built in this run (a file read or two: no subprocess, no import of the build types,
    which a no-op build never loads)."""
    cmake = [r.package for r in results
             if inputs.is_file(selection.workspace.build_base / r.package / "CMakeCache.txt")]
    if not cmake:
        return "none (no CMake package)"
    built_now = _built_now(results)
    built = [n for n in cmake if n in built_now]
    for name in [*built, *cmake][:2]:
        try:
            text = (selection.workspace.build_base / name / "CMakeCache.txt").read_text(
                errors="replace")
        except OSError:
            continue
        found = _GENERATOR.search(text)
        if found:
            return found.group(1).strip()
    return "not configured"


def _built_now(results: Iterable[JobResult]) -> set[str]:
    return {r.package for r in results
            if r.outcome is Outcome.FINISHED and not r.restored}


def report_data(selection: Selection, facts: RunFacts, run_log: Path, jobs: JobGraph,
               results: Sequence[JobResult], samples: Sequence[CpuSample], origin: float,
               extra: Mapping[str, Mapping[str, object]] | None = None) -> dict[str, object]:
    """report.json of a run: each package with its dependencies among the run's `jobs` and its
    result; `extra` adds to or replaces a package's fields (a test run's counts and failing
    tests). A build also names its CMake generator and its build cache."""
    building = facts.verb == "build"
    packages = []
    for result in sorted(results, key=lambda r: r.package):
        package = selection.packages[result.package]
        packages.append({
            "name": result.package, "build_type": package.build_type,
            "path": str(package.path),
            "build_dir": str(selection.workspace.build_base / result.package),
            "dependencies": sorted(jobs.dependencies.get(result.package, ())),
            **({"restored": result.restored} if building else {}),
            **_result_fields(result, run_log),
            **(extra or {}).get(result.package, {}),
        })
    compiler = dict(facts.compiler) if facts.compiler is not None else None
    return {
        "format": FORMAT, "verb": facts.verb, "command": command_line(),
        "version": __version__, "started": started_at(origin),
        "workspace": str(selection.workspace.root),
        "cores": facts.cores, "workers": facts.workers,
        "generator": _generator(selection, results) if building else "",
        "compiler_cache": compiler, "compiler_cache_choice": facts.compiler_cache_choice,
        "artifact_cache": artifact_cache_text(facts.cache, facts.symlink_install)
        if building else "",
        "packages": packages,
        "cpu": [[s.time, s.busy] for s in samples],
    }


def write_report_json(run_log: Path, record: Mapping[str, object]) -> Path:
    path = run_log / REPORT_JSON
    # a message or a command line may quote a URL with its credentials
    path.write_text(redact(json.dumps(record, indent=1, sort_keys=True)) + "\n",
                    encoding="utf-8")
    return path
