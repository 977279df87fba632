"""The `ament_cmake` build type: the cmake recipe plus ament's symlink install and test handling."""

from __future__ import annotations

from dataclasses import dataclass

from wsbuild.build_types import PackageContext, TypeOption
from wsbuild.build_types.cmake import CMAKE_OWN_TARGETS, CMakeBuildType, cmake_options
from wsbuild.build_types.cmake_options import AMENT_CMAKE_OPTIONS
from wsbuild.prefix.hooks import EnvironmentHooks


@dataclass(frozen=True, slots=True)
class AmentCMakeBuildType(CMakeBuildType):
    """The `ament_cmake` build type: CMake's steps, with the ament hooks and options."""

    name: str = "ament_cmake"
    hooks: EnvironmentHooks = EnvironmentHooks(cmake_prefix_path=True, ament=True,
                                               ament_local_setup=True)
    estimate_base: float = 2.0
    #: the CMake options and --ament-cmake-args (cmake_options.py)
    options: tuple[TypeOption, ...] = AMENT_CMAKE_OPTIONS
    #: ament_cmake_python's always-run targets: a copy of the package's Python code (or the
    #: generated messages') and its `setup.py egg_info`, made again each build from the same
    #: files (their reads are observed like any step's): no volatile build
    deterministic_targets: tuple[str, ...] = (*CMAKE_OWN_TARGETS,
                                              "CMakeFiles/ament_cmake_python_copy_*",
                                              "CMakeFiles/ament_cmake_python_build_*_egg")
    #: what reads package.xml in its build, refusing what wsbuild only warns about (an
    #: unknown element or attribute, an email without a two-letter domain): the package's
    #: `refused` problems are errors before its build starts (verbs/load.py)
    manifest_reader: str = "ament_cmake's package.xml reader (catkin_pkg)"

    def installs_in_place(self, ctx: PackageContext) -> bool:
        return ctx.options.symlink_install

    def install_mode_switched(self, ctx: PackageContext) -> str:
        """A build directory built with the other install mode: its ament_cmake_python copies
        (or links) and symlink-install scripts make the next build fail ("failed to create
        symbolic link ... Is a directory"), and the cache keeps AMENT_CMAKE_SYMLINK_INSTALL."""
        cached = self.state(ctx).symlink_install
        if cached is None or cached == ctx.options.symlink_install:
            return ""
        return "with --symlink-install, this build is without" if cached else \
            "without --symlink-install, this build is with it"

    def configure_args(self, ctx: PackageContext) -> list[str]:
        args = CMakeBuildType.configure_args(self, ctx)
        if ctx.options.symlink_install:
            args.insert(1, "-DAMENT_CMAKE_SYMLINK_INSTALL=1")
        # after the other CMake arguments, as colcon-ros appends them
        return [*args, *cmake_options(ctx).ament_args]


BUILD_TYPE = AmentCMakeBuildType()
