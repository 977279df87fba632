"""The `python` build type: a setup.py / setup.cfg / pyproject.toml package, standards-based.

Its steps come from `build_types/pybuild/recipe.py`, imported only when a package is built: deciding
that a package is up to date loads nothing of the Python packaging machinery.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from wsbuild.build_types import PackageContext, BuildTypeBase, RunnerNamed, Step

if TYPE_CHECKING:
    from wsbuild.build_types.pybuild.recipe import PythonBuildPlan


@dataclass(frozen=True, slots=True)
class PythonBuildType(BuildTypeBase):
    name: str = "python"

    test_runner = RunnerNamed("wsbuild.build_types.pybuild.tests:PYTEST")

    def steps(self, ctx: PackageContext) -> list[Step]:
        return python_steps(ctx)


BUILD_TYPE = PythonBuildType()


@dataclass(slots=True)
class PythonBuild:
    """One package's build: `configure` decides the plan `install` follows."""

    plan: PythonBuildPlan | None = None

    def configure(self, ctx: PackageContext) -> None:
        from wsbuild.build_types.pybuild.recipe import configure

        self.plan = configure(ctx)

    def install(self, ctx: PackageContext) -> None:
        from wsbuild.build_types.pybuild.recipe import install

        install(ctx, self.plan)


#: what each in-process step does (printed by `--dry-run` next to its by-hand command)
DESCRIPTIONS = {
    "configure": "read what setup() installs (setup.py in wsbuild's warm helper process) and "
                 "choose between placing the files and a PEP 517 wheel",
    "install": "place the files into the stage, or build the wheel and install it there",
    "index": "install the ament index marker and package.xml if setup.py did not",
    "record": "keep the list of installed files in the build directory",
}


def python_steps(ctx: PackageContext, *,
                 extra: Mapping[str, Callable[[PackageContext], None]] | None = None) -> list[Step]:
    """The recipe's steps: in-process, because the helper stays warm across packages and the
    files go straight into the stage; each with the by-hand command that does the same.
    `extra`: a build type's own steps after `install` (ament_python's `index`)."""
    from wsbuild.build_types.pybuild.by_hand import STEPS as BY_HAND_STEPS
    from wsbuild.build_types.pybuild.by_hand import by_hand_command

    build = PythonBuild()
    actions: dict[str, Callable[[PackageContext], None]] = {
        "configure": build.configure, "install": build.install, **(extra or {})}
    actions["record"] = record
    source = ctx.source_dir.absolute()
    reads = {"configure": (source,), "install": (source, ctx.build_dir), "index": (source,),
             "record": (ctx.stage_prefix,)}
    writes = {"configure": (ctx.build_dir,), "install": (ctx.install_prefix,),
              "index": (ctx.install_prefix,), "record": (ctx.build_dir,)}
    return [Step(label, action, description=DESCRIPTIONS.get(label, label),
                 by_hand=by_hand_command(label, ctx) if label in BY_HAND_STEPS else None,
                 reads=reads.get(label, ()), writes=writes.get(label, ()))
            for label, action in actions.items()]


def record(ctx: PackageContext) -> None:
    """Keep the list of installed files in the build directory."""
    from wsbuild.build_types.pybuild.recipe import record as record_files

    record_files(ctx)
