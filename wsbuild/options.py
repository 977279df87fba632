"""Validated, frozen option records for the verbs that do work."""

from __future__ import annotations

import argparse
import os
import shlex
import sys
from dataclasses import dataclass

from wsbuild.build_types import BuildOptions
from wsbuild.errors import WsbuildError


@dataclass(frozen=True, slots=True)
class RunOptions:
    """How packages are scheduled and reported (shared by build and test)."""

    workers: int
    sequential: bool
    continue_on_error: bool
    wait_for_lock: bool


@dataclass(frozen=True, slots=True)
class BuildRequest:
    build: BuildOptions
    run: RunOptions
    skip_dependency_check: bool = False
    force: bool = False
    repair_underlay: bool = True


def cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def _split_args(values: list[str] | None) -> tuple[str, ...]:
    # `--cmake-args -DX=1 "-DY=a b"` arrives as separate argv items; a single quoted item holding
    # several arguments is split the way a shell would
    result: list[str] = []
    for value in values or []:
        if not value:
            continue
        result.extend(shlex.split(value) if " " in value and not value.startswith("-D") else [value])
    return tuple(result)


def build_request(args: argparse.Namespace) -> BuildRequest:
    workers = args.parallel_workers if args.parallel_workers is not None else cpu_count()
    if workers < 1:
        raise WsbuildError(f"--parallel-workers must be at least 1, got {workers}")
    sequential = args.executor == "sequential"
    return BuildRequest(
        build=BuildOptions(
            symlink_install=args.symlink_install,
            merge_install=args.merge_install,
            cmake_args=_split_args(args.cmake_args),
            cmake_target=args.cmake_target,
            cmake_clean_cache=args.cmake_clean_cache,
            cmake_clean_first=args.cmake_clean_first,
            cmake_force_configure=args.cmake_force_configure,
            jobs=cpu_count(),
            python_executable=sys.executable,
        ),
        run=RunOptions(
            workers=1 if sequential else workers,
            sequential=sequential,
            continue_on_error=args.continue_on_error,
            wait_for_lock=not args.no_wait,
        ),
        skip_dependency_check=args.skip_dependency_check,
        force=getattr(args, "force", False),
    )
