"""Per-package environment files colcon writes into a prefix: hooks, package.*, index entries."""

from __future__ import annotations

import os
import shutil
import sysconfig
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from wsbuild.errors import WsbuildError
from wsbuild.files import write_if_changed
from wsbuild.prefix.layout import AMENT_PACKAGE_INDEX, PACKAGE_INDEX
from wsbuild.prefix.quoting import prefixed_word, sh_quote, validate_package_name
from wsbuild.prefix.render import load_template, render
from wsbuild.patterns import lazy

#: the shell extensions wsbuild writes package scripts for, with `.dsv` (colcon's sorted order)
SHELL_EXTENSIONS = ("bash", "dsv", "sh", "zsh")

_SAFE_SUBDIRECTORY = lazy(r"^[A-Za-z0-9_.+-]+(/[A-Za-z0-9_.+-]+)*$")


@dataclass(frozen=True, slots=True)
class EnvironmentHooks:
    """What a package's build type says about its environment (each build type sets its own)."""

    #: a CMake project: its prefix always goes on CMAKE_PREFIX_PATH
    cmake_prefix_path: bool = False
    #: a ROS package even before its package.xml is installed: AMENT_PREFIX_PATH and the
    #: ament index marker
    ament: bool = False
    #: colcon-ros's pkg_config_path hooks once a package.xml is installed (plain CMake packages)
    pkg_config_path: bool = False
    #: ament's own `share/<pkg>/local_setup.*` (an ament_cmake install target) are sourced
    ament_local_setup: bool = False


@dataclass(frozen=True, slots=True)
class Hook:
    """One `share/<pkg>/hook/<name>.{dsv,sh}` pair prepending `<prefix>/<subdirectory>`."""

    name: str
    variable: str
    #: relative to the prefix; "" stands for the prefix itself
    subdirectory: str


def environment_hooks(
    prefix: Path, package: str, *, hooks: EnvironmentHooks, python_site: str
) -> list[Hook]:
    """The hooks colcon would create for this installed package, in colcon's order.

    First colcon's environment extensions (sorted by name: cmake_module_path,
    cmake_prefix_path, library_path, path, pkg_config, pythonpath, pythonscriptspath), then
    what the build type adds (colcon-ros: ament_prefix_path for ament_python, pkg_config_path
    for a cmake package with a package.xml). wsbuild differs from colcon in two ways: a
    CMake package's prefix always goes on CMAKE_PREFIX_PATH (find_library/find_program use
    it too), and every package with a package.xml gets AMENT_PREFIX_PATH, so the ament index
    marker wsbuild installs for it is found.
    """
    found: list[Hook] = []
    found += _cmake_module_path_hooks(prefix, package)
    if hooks.cmake_prefix_path or _has_cmake_config(prefix, package):
        found.append(Hook("cmake_prefix_path", "CMAKE_PREFIX_PATH", ""))
    for directory in sorted(prefix.glob("lib*")):
        if directory.is_dir() and any(directory.glob("*.so")):
            found.append(Hook(f"ld_library_path_{directory.name}", "LD_LIBRARY_PATH", directory.name))
    has_scripts = _has_file(prefix / "bin")
    if has_scripts:
        found.append(Hook("path", "PATH", "bin"))
    if (prefix / "lib" / "pkgconfig" / f"{package}.pc").is_file():
        found.append(Hook("pkg_config", "PKG_CONFIG_PATH", "lib/pkgconfig"))
    site = _checked_subdirectory(str(PurePosixPath(python_site)))
    if (prefix / site).exists():
        found.append(Hook("pythonpath", "PYTHONPATH", site))
    if has_scripts:
        # colcon's pythonscriptspath: the `scripts` path of the posix_prefix scheme is bin/
        found.append(Hook("pythonscriptspath", "PATH", "bin"))

    has_manifest = (prefix / "share" / package / "package.xml").is_file()
    if hooks.pkg_config_path and has_manifest:
        found.append(Hook("pkg_config_path", "PKG_CONFIG_PATH", "lib/pkgconfig"))
        multiarch = sysconfig.get_config_var("MULTIARCH")
        if multiarch:
            found.append(
                Hook("pkg_config_path_multiarch", "PKG_CONFIG_PATH", f"lib/{multiarch}/pkgconfig")
            )
    if _needs_ament_prefix_path(prefix, package, hooks, has_manifest):
        found.append(Hook("ament_prefix_path", "AMENT_PREFIX_PATH", ""))
    return found


def has_ament_local_setup(prefix: Path, package: str) -> bool:
    """True when ament installed `share/<pkg>/local_setup.*` (an ament_cmake install target)."""
    share = prefix / "share" / package
    return (share / "local_setup.dsv").is_file() or (share / "local_setup.sh").is_file()


def is_ros_package(prefix: Path, package: str, hooks: EnvironmentHooks) -> bool:
    """A package the ament index should list: an ament build type or one with a package.xml."""
    return hooks.ament or (prefix / "share" / package / "package.xml").is_file()


def write_package_environment(
    prefix: Path,
    package: str,
    run_dependencies: Iterable[str],
    *,
    hooks: EnvironmentHooks,
    python_site: str,
    install_prefix: Path | None = None,
) -> list[Path]:
    """Write the environment files of a package already installed in `prefix`.

    `prefix` is `install/<pkg>` (isolated) or `install/` (merged), or a staging directory
    holding the package's files; then `install_prefix` names where they will live (the only
    path written into a file: package.sh's fallback prefix). Writes
    `share/<pkg>/hook/<name>.{dsv,sh}`, `share/<pkg>/package.{dsv,sh,bash,zsh}`,
    `share/colcon-core/packages/<pkg>` (run dependencies, sorted, colon-separated) and, for a
    ROS package, the ament index marker when missing. Files are written only when their
    content changes; the paths actually written are returned.
    """
    validate_package_name(package)
    dependencies = sorted(set(run_dependencies))
    for dependency in dependencies:
        if not dependency or os.pathsep in dependency or "\n" in dependency:
            raise WsbuildError(
                f"invalid run dependency name {dependency!r} of package '{package}'",
                hint="dependency names cannot be empty or contain ':' or a newline",
            )
    found = environment_hooks(prefix, package, hooks=hooks, python_site=python_site)
    share = PurePosixPath("share", package)

    # what package.dsv lists (relative to the prefix), in colcon's order
    listed: list[str] = []
    for hook in found:
        listed += [f"{share}/hook/{hook.name}.dsv", f"{share}/hook/{hook.name}.sh"]
    if hooks.ament_local_setup and has_ament_local_setup(prefix, package):
        listed += [f"{share}/local_setup.{ext}" for ext in SHELL_EXTENSIONS]

    files: dict[Path, str] = {}
    for hook in found:
        mode = "prepend-non-duplicate"
        files[prefix / share / "hook" / f"{hook.name}.dsv"] = (
            f"{mode};{hook.variable};{hook.subdirectory}\n"
        )
        files[prefix / share / "hook" / f"{hook.name}.sh"] = render(
            "hook_prepend_value.sh",
            NAME=hook.variable,
            VALUE=prefixed_word("COLCON_CURRENT_PREFIX", hook.subdirectory),
        )
    files[prefix / share / "package.dsv"] = "".join(f"source;{path}\n" for path in listed)
    files[prefix / share / "package.sh"] = _package_sh(install_prefix or prefix, listed)
    for shell in ("bash", "zsh"):
        files[prefix / share / f"package.{shell}"] = _package_script(shell, package, listed)
    files[prefix / PACKAGE_INDEX / package] = os.pathsep.join(dependencies)

    written = [path for path, content in files.items() if write_if_changed(path, content)]
    marker = prefix / AMENT_PACKAGE_INDEX / package
    if is_ros_package(prefix, package, hooks) and not os.path.lexists(marker):
        write_if_changed(marker, "")
        written.append(marker)
    return written


def register_package_files(
    prefix: Path, package: str, manifest: Path | None, *, symlink: bool = False
) -> list[Path]:
    """Install the ament index marker and `share/<pkg>/package.xml` of a ROS package if missing.

    What colcon-ros does implicitly for ament_python packages, and wsbuild also for a plain
    cmake package with a package.xml. Without a manifest nothing is installed (the package
    is not a ROS package). `symlink` links the manifest instead of copying it
    (`--symlink-install`). Returns the paths created.
    """
    validate_package_name(package)
    if manifest is None:
        return []
    written: list[Path] = []
    installed = prefix / "share" / package / "package.xml"
    if not os.path.lexists(installed):
        installed.parent.mkdir(parents=True, exist_ok=True)
        if symlink:
            installed.symlink_to(manifest.resolve())
        else:
            shutil.copyfile(manifest, installed)
        written.append(installed)
    marker = prefix / AMENT_PACKAGE_INDEX / package
    if not os.path.lexists(marker):
        write_if_changed(marker, "")
        written.append(marker)
    return written


def _package_sh(prefix: Path, listed: list[str]) -> str:
    scripts = [path for path in listed if path.endswith(".sh")]
    hooks_block = ""
    if scripts:
        hooks_block = render(
            "package_hooks.sh",
            BUILD_PREFIX=sh_quote(os.path.abspath(prefix)),
            HOOKS="".join(
                f"_colcon_package_sh_source_script {prefixed_word('COLCON_CURRENT_PREFIX', p)}\n"
                for p in scripts
            ),
        )
    return render(
        "package.sh",
        PREPEND_UNIQUE_VALUE=load_template("prepend_unique_value.sh"),
        HOOKS_BLOCK=hooks_block,
    )


def _package_script(shell: str, package: str, listed: list[str]) -> str:
    scripts = [path for path in listed if path.endswith(f".{shell}")]
    hooks_block = ""
    if scripts:
        hooks_block = (
            "\n# setting COLCON_CURRENT_PREFIX avoids determining the prefix in the sourced scripts\n"
            f'COLCON_CURRENT_PREFIX="$_colcon_package_{shell}_COLCON_CURRENT_PREFIX"\n'
            f"\n# source {shell} hooks\n"
            + "".join(
                f"_colcon_package_{shell}_source_script "
                f"{prefixed_word('COLCON_CURRENT_PREFIX', p)}\n"
                for p in scripts
            )
        )
    values = {"PACKAGE": package, "HOOKS_BLOCK": hooks_block}
    if shell == "bash":
        values["ABSPATH"] = render("abspath.bash", FUNC="_wsb_package_abspath")
    return render(f"package.{shell}", **values)


def _needs_ament_prefix_path(prefix: Path, package: str, traits: EnvironmentHooks,
                             has_manifest: bool) -> bool:
    if traits.ament_local_setup and has_ament_local_setup(prefix, package):
        # ament's own local_setup hooks prepend AMENT_PREFIX_PATH
        return False
    return traits.ament or has_manifest


def _checked_subdirectory(subdirectory: str) -> str:
    if not _SAFE_SUBDIRECTORY.fullmatch(subdirectory) or ".." in subdirectory.split("/"):
        raise WsbuildError(
            f"unexpected Python install directory {subdirectory!r}",
            hint="expected a relative path like lib/python3.12/site-packages",
        )
    return subdirectory


def _has_file(directory: Path) -> bool:
    """colcon's check for bin/: the directory holds at least one file."""
    try:
        return any(child.is_file() for child in directory.iterdir())
    except (FileNotFoundError, NotADirectoryError):
        return False


def _has_cmake_config(prefix: Path, package: str) -> bool:
    """colcon-cmake's check: a `*Config.cmake`/`*-config.cmake` anywhere in the prefix.

    Only done for an isolated prefix: in a merged one every package would match through
    the others' files (and walking the whole install tree per package is slow).
    """
    if prefix.name != package:
        return False
    for _root, _dirs, filenames in os.walk(prefix):
        if any(f.endswith(("-config.cmake", "Config.cmake")) for f in filenames):
            return True
    return False


def _cmake_module_path_hooks(prefix: Path, package: str) -> list[Hook]:
    """colcon-cmake's CMAKE_MODULE_PATH hooks: directories holding `Find*.cmake` modules."""
    candidates = [
        *(f"{lib}/cmake/{package}" for lib in ("lib64", "lib32", "libx32", "lib")),
        f"share/cmake/{package}",
        *(f"{lib}/{package}" for lib in ("lib64", "lib32", "libx32", "lib")),
        f"share/{package}",
        *(f"{lib}/{package}/cmake" for lib in ("lib64", "lib32", "libx32", "lib")),
        *(f"{lib}/{package}/CMake" for lib in ("lib64", "lib32", "libx32", "lib")),
        f"share/{package}/cmake",
        f"share/{package}/CMake",
    ]
    hooks: list[Hook] = []
    seen: list[Path] = []
    for relative in candidates:
        directory = prefix / relative
        if not directory.is_dir():
            continue
        # skip paths which are the same but only differ in case
        if any(directory.samefile(other) for other in seen):
            continue
        if any(
            f.name.startswith("Find") and f.name.endswith(".cmake") and f.is_file()
            for f in directory.iterdir()
        ):
            suffix = str(len(hooks)) if hooks else ""
            hooks.append(Hook(f"cmake_module_path{suffix}", "CMAKE_MODULE_PATH", relative))
            seen.append(directory)
    return hooks
