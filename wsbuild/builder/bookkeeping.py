"""The builder's own work around a package's build-type steps: each a labelled step that runs
in wsbuild's process, decided by the plan (builder/plan.py), printed by `--dry-run`
(builder/plan_text.py) and announced as it starts, as the build type's steps are
(builder/package.py runs them)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class BuilderStep:
    """One piece of the builder's own work for a package: its label and what it does."""

    label: str
    description: str


START_COMPILER_CACHE = BuilderStep(
    "start compiler cache", "start the compiler cache's server if it is not running (the "
    "compilers' launcher)")
ADVANCE_TIMES = BuilderStep(
    "advance times", "give the current time to each file the last build read whose content "
    "changed while its time did not advance past the outputs (make and Ninja compare times)")
REGISTER = BuilderStep(
    "register", "write package.xml, the ament index marker and the environment hooks into "
    "the stage")
COMMIT = BuilderStep("commit", "commit the stage into install/, replacing the package's install")

#: after the build type's steps, every build
AFTER = (REGISTER, COMMIT)


def before(*, compiler_cache: bool, built_before: bool) -> tuple[BuilderStep, ...]:
    """The builder's steps before the build type's: the compiler cache's server when the run
    launches the compilers through one; the times of what the last build read when there is
    a last build."""
    return ((START_COMPILER_CACHE,) if compiler_cache else ()) + \
        ((ADVANCE_TIMES,) if built_before else ())
