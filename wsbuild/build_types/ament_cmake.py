"""The `ament_cmake` build type: the cmake recipe plus ament's symlink install and test handling."""

from __future__ import annotations

from dataclasses import dataclass

from wsbuild.build_types import BuildContext
from wsbuild.build_types.cmake import CMakeBuildType


@dataclass(frozen=True, slots=True)
class AmentCMakeBuildType(CMakeBuildType):
    name: str = "ament_cmake"

    def installs_in_place(self, ctx: BuildContext) -> bool:
        return ctx.options.symlink_install

    def configure_args(self, ctx: BuildContext) -> list[str]:
        args = CMakeBuildType.configure_args(self, ctx)
        if ctx.options.symlink_install:
            args.insert(1, "-DAMENT_CMAKE_SYMLINK_INSTALL=1")
        return args


BUILD_TYPE = AmentCMakeBuildType()
