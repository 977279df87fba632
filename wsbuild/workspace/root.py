"""The workspace on disk: its root, and where build/, install/ and log/ live."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from wsbuild import inputs

#: files that make a directory a package (so it cannot be a workspace root)
PACKAGE_MARKERS = ("package.xml", "CMakeLists.txt", "setup.py", "setup.cfg", "pyproject.toml")
#: written into build/ (as colcon does) so a later run recognises the workspace from inside it
BUILD_MARKER = ".built_by"
#: the default bases, relative to the workspace root (colcon's): the one place that names them
BUILD_BASE, INSTALL_BASE, LOG_BASE = "build", "install", "log"


@dataclass(frozen=True, slots=True)
class Workspace:
    """A workspace's root and its build, install and log bases."""

    root: Path
    build_base: Path
    install_base: Path
    log_base: Path

    @classmethod
    def at(
        cls,
        root: Path,
        *,
        build_base: str = BUILD_BASE,
        install_base: str = INSTALL_BASE,
        log_base: str = LOG_BASE,
    ) -> Workspace:
        return cls(
            root=root,
            build_base=(root / build_base).absolute(),
            install_base=(root / install_base).absolute(),
            log_base=(root / log_base).absolute(),
        )

    def default_base_paths(self) -> list[Path]:
        src = self.root / "src"
        return [src] if inputs.is_dir(src) else [self.root]


def _is_package_dir(path: Path) -> bool:
    return any(inputs.exists(path / marker) for marker in PACKAGE_MARKERS)


def _is_workspace_dir(path: Path) -> bool:
    if inputs.exists(path / BUILD_BASE / BUILD_MARKER) or inputs.exists(
        path / INSTALL_BASE / ".colcon_install_layout"
    ):
        return True
    return (path / "src").is_dir() and not _is_package_dir(path)


def why_workspace_root(root: Path, start: Path) -> str:
    """Why `find_workspace_root(start)` chose `root`, in words ("" when it is `start`, where
    nobody wonders): a `wsbuild build` in `src/pkg` builds the workspace above it."""
    start = start.absolute()
    if root == start:
        return ""
    if inputs.exists(root / BUILD_BASE / BUILD_MARKER):
        holds = f"{BUILD_BASE}/ of an earlier build"
    elif inputs.exists(root / INSTALL_BASE / ".colcon_install_layout"):
        holds = f"an {INSTALL_BASE}/ of colcon's"
    else:
        holds = "src/"
    return (f"workspace {root}: the nearest directory above {start} holding {holds} "
            "(-C DIR names another)")


def find_workspace_root(start: Path) -> Path:
    """The nearest directory at or above `start` that holds `src/` or a wsbuild/colcon build.

    A package's own `src/` folder (C++ sources) does not count: a directory that is itself a
    package is never a workspace root. Without any match, `start` is the workspace (colcon's rule).
    """
    start = start.absolute()
    for candidate in (start, *start.parents):
        if _is_workspace_dir(candidate):
            return candidate
    return start
