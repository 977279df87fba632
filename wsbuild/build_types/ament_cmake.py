"""The `ament_cmake` build type: the cmake recipe plus ament's symlink install and test handling."""

from __future__ import annotations

from dataclasses import dataclass

from wsbuild.build_types import BuildContext, BuildOptions, cmake_key_options
from wsbuild.build_types.cmake import CMakeBuildType
from wsbuild.prefix.hooks import EnvironmentHooks


@dataclass(frozen=True, slots=True)
class AmentCMakeBuildType(CMakeBuildType):
    name: str = "ament_cmake"
    hooks: EnvironmentHooks = EnvironmentHooks(cmake_prefix_path=True, ament=True,
                                               ament_local_setup=True)
    estimate_base: float = 2.0

    def installs_in_place(self, ctx: BuildContext) -> bool:
        return ctx.options.symlink_install

    def key_options(self, options: BuildOptions) -> dict[str, object]:
        return cmake_key_options(options)

    def configure_args(self, ctx: BuildContext) -> list[str]:
        args = CMakeBuildType.configure_args(self, ctx)
        if ctx.options.symlink_install:
            args.insert(1, "-DAMENT_CMAKE_SYMLINK_INSTALL=1")
        # after the other CMake arguments, as colcon-ros appends them
        return [*args, *ctx.options.ament_cmake_args]


BUILD_TYPE = AmentCMakeBuildType()
