"""The `ament_python` build type: the `python` recipe plus the ament index marker and package.xml
(build_types/pybuild/index.py), which it hands the recipe as its extra step.

Like colcon-ros, a package whose setup.py forgets to install the marker
`share/ament_index/resource_index/packages/<pkg>` or `share/<pkg>/package.xml` still gets
them, with a warning that says what to add to `data_files`.
"""

from __future__ import annotations

from dataclasses import dataclass

from wsbuild.build_types import PackageContext, BuildTypeBase, RunnerNamed, Step
from wsbuild.build_types.python import close_python_run, python_steps
from wsbuild.prefix.hooks import EnvironmentHooks


@dataclass(frozen=True, slots=True)
class AmentPythonBuildType(BuildTypeBase):
    """The `ament_python` build type: setup.py's build and install, with the ament hooks."""

    name: str = "ament_python"
    hooks: EnvironmentHooks = EnvironmentHooks(ament=True)

    test_runner = RunnerNamed("wsbuild.build_types.pybuild.tests:PYTEST")

    def steps(self, ctx: PackageContext) -> list[Step]:
        return python_steps(ctx, extra={"index": register})

    def close_run(self) -> None:
        close_python_run()


BUILD_TYPE = AmentPythonBuildType()


def register(ctx: PackageContext) -> None:
    """The `index` step: the ament index marker and package.xml, if setup.py did not."""
    from wsbuild.build_types.pybuild.index import (
        register as install_index)  # lazy: off the full no-op build

    install_index(ctx)
