"""What a package build observes (observe/steps.py): its steps, each into a directory of its
own; what wsbuild sets for this run only and a compiler cache's own state are no input of its
record; under the suite's build-step oracle (builder/oracles/step_trace.py) its warm helpers run
traced too, and the oracle leaves out the observer's files and the compiler cache's
storage."""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.observe.steps import OBSERVE_DIR, StepObservations

if TYPE_CHECKING:
    from wsbuild.builder.job import RunResources
    from wsbuild.builder.oracles.step_trace import StepTraces


def observations_of(run: RunResources, build_dir: Path, traces: StepTraces,
                    run_environ: Mapping[str, str]) -> StepObservations:
    """A fresh record of what the steps of a package's build (in `build_dir`) read
    (observe/steps.py): what wsbuild sets for this run only and a compiler cache's own state
    are no input; under the oracle (`traces` on) its warm helpers run traced."""
    compilers = run.compilers
    observations = StepObservations(
        build_dir / OBSERVE_DIR, run.session.observer,
        run_only=set(run_environ),
        tool_state=compilers.state_dirs() if compilers is not None else (),
        tool_variables=compilers.own_variables if compilers is not None else {},
        tracer=functools.partial(_trace, traces, build_dir) if traces.on else None)
    observations.start()
    return observations


def not_inputs(run: RunResources) -> tuple[Path, ...]:
    """What the build-step oracle does not hold to the record: the observer's files and a
    compiler cache's storage."""
    observer = run.session.observer
    found = [observer.library.parent] if not isinstance(observer, str) else []
    if run.compilers is not None:
        found += run.compilers.state_dirs()
    return tuple(found)


def _trace(traces: StepTraces, build_dir: Path, argv: Sequence[str], label: str,
           env: Mapping[str, str]) -> tuple[Sequence[str], Mapping[str, str]]:
    """A program of an in-process step (a warm helper) under the build-step oracle."""
    return traces.command(argv, label, build_dir, env)


def reproducible(run: RunResources, delta: Mapping[str, str]) -> dict[str, str]:
    """A step's environment `delta` without the variables that name this run's resources,
    which a shell after the run does not have (what the reproduce script sets): the
    jobserver's descriptors, the private directories of the compiler cache (stats logs, the
    sccache server's socket) and of distcc."""
    private = [str(run.compilers.private_dir)] if run.compilers is not None else []
    if run.distribution is not None:
        private.append(str(run.distribution.private_dir))
    return {k: v for k, v in delta.items()
            if not (k == "MAKEFLAGS" and v == run.jobserver.makeflags)
            and not any(directory in v for directory in private)}
