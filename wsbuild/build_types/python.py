"""The `python` build type: a setup.py / setup.cfg / pyproject.toml package, standards-based.

Its steps come from `build_types/pybuild/recipe.py`, imported only when a package is built: deciding
that a package is up to date loads nothing of the Python packaging machinery.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from wsbuild.build_types import BuildContext, BuildTypeBase, Step, TestTool

if TYPE_CHECKING:
    from wsbuild.build_types.pybuild.recipe import PythonBuildPlan


@dataclass(frozen=True, slots=True)
class PythonBuildType(BuildTypeBase):
    name: str = "python"
    test_tool: TestTool | None = TestTool.PYTEST

    def steps(self, ctx: BuildContext) -> list[Step]:
        build = PythonBuild()
        return [Step("configure", build.configure), Step("install", build.install),
                Step("record", record)]


BUILD_TYPE = PythonBuildType()


@dataclass(slots=True)
class PythonBuild:
    """One package's build: `configure` decides the plan `install` follows."""

    plan: PythonBuildPlan | None = None

    def configure(self, ctx: BuildContext) -> None:
        from wsbuild.build_types.pybuild.recipe import configure

        self.plan = configure(ctx)

    def install(self, ctx: BuildContext) -> None:
        from wsbuild.build_types.pybuild.recipe import install

        install(ctx, self.plan)


def record(ctx: BuildContext) -> None:
    """Keep the list of installed files in the build directory."""
    from wsbuild.build_types.pybuild.recipe import record as record_files

    record_files(ctx)
