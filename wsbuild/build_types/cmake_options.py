"""The options of `wsbuild build` the CMake build types declare (cmake.py, ament_cmake.py), as
colcon-cmake and colcon-ros add them, and `CMakeOptions`, their values for one package.

A module of its own, importing nothing heavy: the command line's parser reads the declarations
(`BUILTIN_OPTIONS` in build_types/__init__.py names them) without importing the build types."""

from __future__ import annotations

from dataclasses import dataclass

from wsbuild.build_types import BuildOptions, TypeOption

CMAKE_ARGS = TypeOption(
    "--cmake-args", "cmake_args", kind="arguments", metavar="ARG",
    help="every configure, e.g. -DCMAKE_BUILD_TYPE=Release; end with --")
CMAKE_TARGET = TypeOption(
    "--cmake-target", "cmake_target", metavar="TARGET",
    help="build this target instead of the default one", secondary=True)
CMAKE_CLEAN_CACHE = TypeOption(
    "--cmake-clean-cache", "cmake_clean_cache", kind="switch", in_key=False,
    forces_build=True, help="remove CMakeCache.txt before configuring", secondary=True)
CMAKE_CLEAN_FIRST = TypeOption(
    "--cmake-clean-first", "cmake_clean_first", kind="switch", in_key=False,
    forces_build=True, help="build the 'clean' target first (then configure and build)",
    secondary=True)
CMAKE_FORCE_CONFIGURE = TypeOption(
    "--cmake-force-configure", "cmake_force_configure", kind="switch", in_key=False,
    forces_build=True, help="configure even when nothing changed")
#: the arguments the underlay needs (the wheel venv's Python, libpython's link flags, the
#: linters' stand-ins): set by the run (builder/plan.py), before the user's --cmake-args
UNDERLAY_CMAKE_ARGS = TypeOption("", "underlay_cmake_args", kind="arguments")
AMENT_CMAKE_ARGS = TypeOption(
    "--ament-cmake-args", "ament_cmake_args", kind="arguments", metavar="ARG",
    help="CMake arguments for ament_cmake packages only, after --cmake-args", secondary=True)

CMAKE_OPTIONS = (CMAKE_ARGS, CMAKE_TARGET, CMAKE_CLEAN_CACHE, CMAKE_CLEAN_FIRST,
                 CMAKE_FORCE_CONFIGURE, UNDERLAY_CMAKE_ARGS)
AMENT_CMAKE_OPTIONS = (*CMAKE_OPTIONS, AMENT_CMAKE_ARGS)


@dataclass(frozen=True, slots=True)
class CMakeOptions:
    """A CMake package's own options, as its build reads them."""

    args: tuple[str, ...] = ()
    target: str | None = None
    clean_cache: bool = False
    clean_first: bool = False
    force_configure: bool = False
    underlay_args: tuple[str, ...] = ()
    #: ament_cmake packages only
    ament_args: tuple[str, ...] = ()

    @classmethod
    def of(cls, options: BuildOptions) -> CMakeOptions:
        return cls(args=tuple(options.value(CMAKE_ARGS)),  # type: ignore[arg-type]
                   target=options.value(CMAKE_TARGET),  # type: ignore[arg-type]
                   clean_cache=bool(options.value(CMAKE_CLEAN_CACHE)),
                   clean_first=bool(options.value(CMAKE_CLEAN_FIRST)),
                   force_configure=bool(options.value(CMAKE_FORCE_CONFIGURE)),
                   underlay_args=tuple(options.value(UNDERLAY_CMAKE_ARGS)),  # type: ignore[arg-type]
                   ament_args=tuple(options.value(AMENT_CMAKE_ARGS)))  # type: ignore[arg-type]
