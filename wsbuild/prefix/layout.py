"""The install layout colcon defines: markers, per-package prefixes and the installed-package index."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path, PurePosixPath

from wsbuild.errors import CycleError, WorkspaceError
from wsbuild.files import create_if_missing, write_if_changed
from wsbuild.prefix.quoting import validate_package_name
from wsbuild import inputs

#: marker in the install base naming its layout (colcon_core.verb.check_and_mark_install_layout)
INSTALL_LAYOUT_MARKER = ".colcon_install_layout"
#: marker that keeps colcon (and wsbuild) from looking for packages inside a directory
IGNORE_MARKER = "COLCON_IGNORE"
#: the colcon package index: one file per package holding its run dependencies
PACKAGE_INDEX = PurePosixPath("share", "colcon-core", "packages")
#: the ament resource index marker directory for packages
AMENT_PACKAGE_INDEX = PurePosixPath("share", "ament_index", "resource_index", "packages")

ISOLATED = "isolated"
MERGED = "merged"


def package_prefix(install_base: Path, package: str, *, merged: bool) -> Path:
    """The prefix a package is installed to: `install/` (merged) or `install/<pkg>`."""
    return install_base if merged else install_base / package


def is_installed(install_base: Path, package: str, *, merged: bool) -> bool:
    """Whether `package` is installed (its colcon package index entry exists)."""
    prefix = package_prefix(install_base, package, merged=merged)
    return inputs.exists(prefix / PACKAGE_INDEX / package)


def resolve_layout(install_base: Path, requested: bool | None, *, verb: str,
                   build_base: Path | None = None) -> bool:
    """Whether a run works on a merged install: as asked (`requested`), else as install/'s
    marker says. Refuses, before anything is touched, a run whose layout is not install/'s."""
    existing = read_install_layout(install_base)
    if requested is None:
        return existing == MERGED
    wanted = MERGED if requested else ISOLATED
    if existing is None or existing == wanted:
        return requested
    if verb == "build":
        flag = "with" if existing == MERGED else "without"
        raise WorkspaceError(
            f"install/ holds an {existing} install but this build is {wanted}",
            path=install_base / INSTALL_LAYOUT_MARKER,
            hint=f"build {flag} --merge-install as before, or start over: `wsbuild clean -y` "
            f"removes {(build_base or install_base.parent / 'build').name}/, "
            f"{install_base.name}/ and log/",
        )
    flag = "without" if requested else "with"
    raise WorkspaceError(
        f"install/ holds a{'n' if existing == ISOLATED else ''} {existing} install",
        path=install_base,
        hint=f"{verb} {flag} --merge-install, as the workspace was built",
    )


def read_install_layout(install_base: Path) -> str | None:
    """'isolated', 'merged', or None when the marker is missing."""
    try:
        return inputs.read_text(install_base / INSTALL_LAYOUT_MARKER).rstrip()
    except (FileNotFoundError, NotADirectoryError):
        return None


def mark_install_layout(install_base: Path, *, merged: bool) -> Path | None:
    """Write the layout marker; refuse an install base created with the other layout.

    Returns the marker path when it was written.
    """
    wanted = MERGED if merged else ISOLATED
    previous = read_install_layout(install_base)
    if previous is not None and previous != wanted:
        change = "remove" if merged else "add"
        raise WorkspaceError(
            f"the install directory was created with the layout '{previous}'",
            path=install_base,
            hint=f"remove the install directory, pick a different one or {change} "
            "the '--merge-install' option",
        )
    marker = install_base / INSTALL_LAYOUT_MARKER
    return marker if write_if_changed(marker, wanted + "\n") else None


def write_ignore_marker(directory: Path) -> Path | None:
    """Put an empty COLCON_IGNORE in `directory` (install/ or build/) unless one exists."""
    marker = directory / IGNORE_MARKER
    return marker if create_if_missing(marker) else None


def read_installed_packages(install_base: Path, *, merged: bool) -> dict[str, tuple[str, ...]]:
    """Package → recorded run dependencies (sorted), from `share/colcon-core/packages`.

    Isolated: `install/<pkg>/share/colcon-core/packages/<pkg>`; merged: every file in
    `install/share/colcon-core/packages/`. Hidden entries are skipped, as colcon does.
    """
    index_files: list[Path] = []
    if merged:
        index_dir = install_base / PACKAGE_INDEX
        if inputs.is_dir(index_dir):
            index_files = [Path(e.path) for e in inputs.scandir(index_dir)
                           if not e.name.startswith(".") and inputs.is_file(e.path)]
    elif inputs.is_dir(install_base):
        for entry in inputs.scandir(install_base):
            if entry.name.startswith(".") or not inputs.is_dir(entry.path):
                continue
            candidate = Path(entry.path) / PACKAGE_INDEX / entry.name
            if inputs.is_file(candidate):
                index_files.append(candidate)
    packages: dict[str, tuple[str, ...]] = {}
    for index_file in sorted(index_files):
        name = validate_package_name(index_file.name, path=index_file)
        content = inputs.read_text(index_file).strip()
        packages[name] = tuple(sorted({d for d in content.split(os.pathsep) if d}))
    return packages


def installed_order(install_base: Path, *, merged: bool) -> list[str]:
    """The installed packages in the order setup scripts apply them."""
    return order_packages(read_installed_packages(install_base, merged=merged))


def order_packages(packages: Mapping[str, Iterable[str]]) -> list[str]:
    """Topological order by run dependencies, ties broken by name (colcon's prefix_util order).

    Dependencies that are not among `packages` are ignored.
    """
    from wsbuild.workspace.graph import toposort  # lazy: off Tab completion and `--help`

    ordered, stuck = toposort(packages)
    if stuck:
        edges = "; ".join(
            f"{n} -> {', '.join(sorted(d for d in packages[n] if d in stuck))}"
            for n in sorted(stuck)
        )
        raise CycleError(
            f"circular run dependencies between installed packages: {edges}",
            hint="fix the exec/build_export dependencies in these package.xml files",
        )
    return ordered
