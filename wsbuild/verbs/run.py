"""`wsbuild run PKG EXECUTABLE [args…]`: the `ros2 run` of wsbuild."""

from __future__ import annotations

import argparse
import difflib
import os
import sys
from collections.abc import Mapping
from pathlib import Path

from wsbuild.errors import SelectionError, WsbuildError
from wsbuild.verbs.arguments import add_install_base_argument, add_workspace_option
from wsbuild.workspace.root import INSTALL_BASE

RUN_DOC = """Run an executable of an installed package (like `ros2 run`).

Looks for lib/<PKG>/<EXECUTABLE> in every prefix on AMENT_PREFIX_PATH, then in this
workspace's install/ (which works even when it is not sourced: its environment is
applied first). Everything after EXECUTABLE, including --ros-args, goes to the executable.

examples:
  wsbuild run demo_nodes_py talker
  wsbuild run demo_nodes_py listener --ros-args -r chatter:=/other -p rate:=2.0
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_workspace_option(parser, found="found from the current directory")
    add_install_base_argument(parser, "install prefix relative to the workspace")
    parser.add_argument("package_name", metavar="PKG")
    # optional: without it, the package's executables are listed
    parser.add_argument("executable_name", metavar="EXECUTABLE", nargs="?")
    parser.add_argument("arguments", nargs=argparse.REMAINDER, metavar="ARGS",
                        help="passed to the executable, e.g. --ros-args -p name:=value")


def _package_prefixes(environ: Mapping[str, str], install_base: Path) -> dict[str, Path]:
    """package -> prefix: AMENT_PREFIX_PATH first (what the user sourced), then this workspace."""
    from wsbuild.workspace.resolve import ament_index  # lazy: off Tab completion and `--help`

    sourced = [Path(p) for p in environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    if _is_merged(install_base):
        own = [install_base]
    else:
        own = sorted(p for p in install_base.iterdir() if p.is_dir()) if install_base.is_dir() \
            else []
    return ament_index([*sourced, *own])


def _is_merged(install_base: Path) -> bool:
    from wsbuild.prefix.layout import MERGED, read_install_layout  # lazy: off `run --help`

    return read_install_layout(install_base) == MERGED


def _executables(prefix: Path, package: str) -> list[str]:
    directory = prefix / "lib" / package
    try:
        return sorted(e.name for e in os.scandir(directory)
                      if e.is_file() and os.access(e.path, os.X_OK))
    except OSError:
        return []


def _suggest(name: str, choices: list[str]) -> str:
    close = difflib.get_close_matches(name, choices, n=3)
    return ("did you mean " + ", ".join(f"'{c}'" for c in close) + "?") if close else ""


def run_executable(args: argparse.Namespace) -> int:
    """Run an executable of an installed package."""
    from wsbuild.verbs.load import workspace_root  # lazy: off Tab completion and `--help`

    root = workspace_root(args.workspace_dir)
    install_base = root / (args.install_base or INSTALL_BASE)
    environ = dict(os.environ)
    prefixes = _package_prefixes(environ, install_base)
    package, executable = args.package_name, args.executable_name
    if package not in prefixes:
        with_exes = sorted(n for n, p in prefixes.items() if _executables(p, n))
        hint = _suggest(package, sorted(prefixes)) or (
            "packages with executables: " + (", ".join(with_exes) if with_exes else "none; "
                                             "build the workspace first: wsbuild build"))
        raise SelectionError(f"package '{package}' not found (looked in AMENT_PREFIX_PATH and "
                             f"{install_base})", hint=hint)
    prefix = prefixes[package]
    available = _executables(prefix, package)
    if executable is None:  # `wsbuild run PKG`: what it can run
        if not available:
            raise SelectionError(f"{package} installs no executables in lib/{package}/",
                                 path=prefix / "lib" / package,
                                 hint="its launch files run with `ros2 launch`" if any(
                                     is_launch_file(p.name) for p in
                                     (prefix / "share" / package).rglob("*")) else None)
        print(f"executables of {package} (wsbuild run {package} EXECUTABLE):")
        for name in available:
            print(f"  {name}")
        return 0
    if executable not in available and is_launch_file(executable):
        raise launch_file_error(package, executable, prefix, prefixes)
    if executable not in available:
        hint = _suggest(executable, available) or (
            f"executables of {package}: {', '.join(available)}" if available
            else f"{package} installs no executables in lib/{package}/")
        raise SelectionError(f"no executable '{executable}' in package '{package}'",
                             path=prefix / "lib" / package, hint=hint)
    if _needs_workspace_environment(environ, prefix, install_base):
        environ = _workspace_environment(install_base, environ)
    command = [str(prefix / "lib" / package / executable), *args.arguments]
    sys.stdout.flush()
    try:
        os.execve(command[0], command, environ)  # Ctrl-C and exit codes go straight to the node
    except OSError as exc:
        raise WsbuildError(f"cannot run {command[0]}: {exc.strerror}",
                           hint="check its shebang line and permissions") from exc
    return 0  # not reached


#: the names `ros2 launch` takes for launch files (launch's own front ends: Python, XML, YAML)
LAUNCH_SUFFIXES = (".launch.py", ".launch.xml", ".launch.yaml", ".launch.yml", "_launch.py")


def is_launch_file(name: str) -> bool:
    return name.endswith(LAUNCH_SUFFIXES)


def launch_file_error(package: str, name: str, prefix: Path,
                      prefixes: Mapping[str, Path]) -> SelectionError:
    """`wsbuild run PKG x.launch.py`: a launch file is no executable; how to run it with
    `ros2 launch`, and where `ros2 launch` comes from when it is not installed (ros2launch has
    no wheel: it is built from source)."""
    share = prefix / "share" / package
    found = sorted(share.rglob(name)) if share.is_dir() else []
    if not found:
        installed = sorted({p.name for p in share.rglob("*") if is_launch_file(p.name)}) \
            if share.is_dir() else []
        return SelectionError(
            f"'{name}' names a launch file, not an executable, and {package} installs none by "
            f"that name", path=share, hint=f"its launch files: {', '.join(installed)}"
            if installed else f"{package} installs no launch files")
    what = f"'{name}' is a launch file ({found[0]}), not an executable"
    command = f"ros2 launch {package} {name}"
    if "ros2launch" in prefixes:
        hint = f"run it with: {command}  (in a shell that sourced install/setup.bash)"
    elif _declares(share / "package.xml", "ros2launch"):
        hint = (f"run it with `{command}`; ros2 launch (the ros2launch package) is not "
                f"installed: {package} declares it (<exec_depend>ros2launch</exec_depend>), but "
                "it has no PyPI wheel; `wsbuild deps install --from-source` fetches it and what "
                "it needs from the distro's index (the index and the source hosts must be "
                "reachable), then `wsbuild build` builds it; offline, install it with ROS 2 "
                "(apt install ros-jazzy-ros2launch) and source /opt/ros/jazzy/setup.bash")
    else:
        hint = (f"run it with `{command}`; ros2 launch (the ros2launch package) is not "
                "installed and has no wheel: declare <exec_depend>ros2launch</exec_depend> "
                f"in {package}'s package.xml, then `wsbuild deps install --from-source` "
                "fetches and `wsbuild build` builds it into this workspace")
    return SelectionError(what, hint=hint)


def _declares(manifest: Path, dependency: str) -> bool:
    """Whether the installed package.xml declares `dependency` as a run dependency."""
    import re

    try:
        text = manifest.read_text()
    except OSError:
        return False
    return re.search(rf"<(exec_depend|depend|run_depend)(\s[^>]*)?>\s*{re.escape(dependency)}"
                     r"\s*</", text) is not None


def _needs_workspace_environment(environ: Mapping[str, str], prefix: Path,
                                 install_base: Path) -> bool:
    """True when the package comes from this workspace but the workspace is not sourced."""
    sourced = environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)
    return str(prefix) not in sourced and prefix.is_relative_to(install_base)


def _workspace_environment(install_base: Path, environ: dict[str, str]) -> dict[str, str]:
    """What `source install/setup.sh` would give, computed without a shell."""
    from wsbuild.prefix import environment_for, installed_order  # lazy: off Tab completion

    merged = _is_merged(install_base)
    pairs = [(install_base if merged else install_base / name, name)
             for name in installed_order(install_base, merged=merged)]
    return environment_for(pairs, environ)
