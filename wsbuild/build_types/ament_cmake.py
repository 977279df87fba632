"""The `ament_cmake` build type: the cmake recipe plus ament's symlink install and test handling."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

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

    def install_mode_switched(self, ctx: BuildContext) -> str:
        """A build directory built with the other install mode: its ament_cmake_python copies
        (or links) and symlink-install scripts make the next build fail ("failed to create
        symbolic link ... Is a directory"), and the cache keeps AMENT_CMAKE_SYMLINK_INSTALL."""
        cached = cached_symlink_install(ctx.build_dir)
        if cached is None or cached == ctx.options.symlink_install:
            return ""
        return "with --symlink-install, this build is without" if cached else \
            "without --symlink-install, this build is with it"

    def key_options(self, options: BuildOptions) -> dict[str, object]:
        return cmake_key_options(options)

    def configure_args(self, ctx: BuildContext) -> list[str]:
        args = CMakeBuildType.configure_args(self, ctx)
        if ctx.options.symlink_install:
            args.insert(1, "-DAMENT_CMAKE_SYMLINK_INSTALL=1")
        # after the other CMake arguments, as colcon-ros appends them
        return [*args, *ctx.options.ament_cmake_args]


BUILD_TYPE = AmentCMakeBuildType()


_SYMLINK_INSTALL = re.compile(r"^AMENT_CMAKE_SYMLINK_INSTALL:[A-Z]+=(.*)$", re.MULTILINE)


def cached_symlink_install(build_dir: Path) -> bool | None:
    """Whether the build directory's CMake cache was configured for a symlink install (None:
    not configured)."""
    try:
        text = (build_dir / "CMakeCache.txt").read_text(errors="replace")
    except OSError:
        return None
    match = _SYMLINK_INSTALL.search(text)
    return match is not None and match.group(1).strip().upper() in ("1", "ON", "TRUE", "YES",
                                                                      "Y")
