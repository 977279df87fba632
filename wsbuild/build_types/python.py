"""The `python` build type: a setup.py / setup.cfg / pyproject.toml package, standards-based.

Its steps come from `build_types/pybuild/recipe.py`, imported only when a package is built: deciding
that a package is up to date loads nothing of the Python packaging machinery.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

from wsbuild.build_types import PackageContext, BuildTypeBase, RunnerNamed, Step


@dataclass(frozen=True, slots=True)
class PythonBuildType(BuildTypeBase):
    """The `python` build type: a plain Python package (setup.py, setup.cfg, pyproject.toml)."""

    name: str = "python"

    test_runner = RunnerNamed("wsbuild.build_types.pybuild.tests:PYTEST")

    def steps(self, ctx: PackageContext) -> list[Step]:
        return python_steps(ctx)

    def close_run(self) -> None:
        close_python_run()


BUILD_TYPE = PythonBuildType()


def close_python_run() -> None:
    """The run's warm setup.py helpers stopped (they run only once a Python package was
    built: nothing is imported to stop none)."""
    import sys

    helpers = sys.modules.get("wsbuild.build_types.pybuild.setup_py")
    if helpers is not None:
        helpers.shutdown_helpers()


def configure(ctx: PackageContext) -> None:
    """Decide how `install` installs (what setup() installs; the fast path or a PEP 517
    wheel): the typed output the install step reads (`ctx.outputs.python_plan`)."""
    from wsbuild.build_types.pybuild.recipe import (
        configure as decide)  # lazy: off the full no-op build

    ctx.outputs.python_plan = decide(ctx)


def install(ctx: PackageContext) -> None:
    """Install into the stage as the configure step decided."""
    from wsbuild.build_types.pybuild.recipe import (
        install as place)  # lazy: off the full no-op build

    place(ctx, ctx.outputs.python_plan)


#: what each in-process step does (printed by `--dry-run` next to its by-hand command)
DESCRIPTIONS = {
    "configure": "read what setup() installs (setup.py in wsbuild's warm helper process) and "
                 "choose between placing the files and a PEP 517 wheel",
    "install": "place the files into the stage, or build the wheel and install it there",
    "index": "install the ament index marker and package.xml if setup.py did not",
}


def python_steps(ctx: PackageContext, *,
                 extra: Mapping[str, Callable[[PackageContext], None]] | None = None) -> list[Step]:
    """The recipe's steps: in-process, because the helper stays warm across packages and the
    files go straight into the stage; each with the by-hand command that does the same.
    `extra`: a build type's own steps after `install` (ament_python's `index`)."""
    from wsbuild.build_types.pybuild.by_hand import (
        STEPS as BY_HAND_STEPS)  # lazy: off the full no-op build
    from wsbuild.build_types.pybuild.by_hand import (
        by_hand_command)  # lazy: off the full no-op build

    actions: dict[str, Callable[[PackageContext], None]] = {
        "configure": configure, "install": install, **(extra or {})}
    source = ctx.source_dir.absolute()
    reads = {"configure": (source,), "install": (source, ctx.build_dir), "index": (source,)}
    writes = {"configure": (ctx.build_dir,), "install": (ctx.install_prefix,),
              "index": (ctx.install_prefix,)}
    return [Step(label, action, description=DESCRIPTIONS.get(label, label),
                 by_hand=by_hand_command(label, ctx) if label in BY_HAND_STEPS else None,
                 reads=reads.get(label, ()), writes=writes.get(label, ()))
            for label, action in actions.items()]

