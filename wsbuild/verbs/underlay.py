"""`wsbuild underlay check|repair`: the ROS virtualenv underlay installed from PyPI wheels."""

from __future__ import annotations

import argparse
import os
import sys

from wsbuild.errors import UnderlayError
from wsbuild.words import plural

UNDERLAY_DOC = """Check or repair a ROS 2 underlay installed from PyPI wheels into the virtualenv.

The ros-jazzy-* wheels export CMake files naming their build machine's paths
(/opt/python/cp3XX-cp3XX/...), which break rosidl_generate_interfaces. `repair`
rewrites those lines to this virtualenv's paths, touching nothing outside it;
`wsbuild build` does the same automatically before building. `check` also lists ROS
packages the wheels' metadata forgot, with the pip command that installs them.

`check` sums up (`--verbose`: every line) and exits 0 when there is nothing to do, 1 when
there is (a repair, a package to install), 2 when there is no underlay.
"""

#: `underlay check`'s exit code when the underlay needs a repair or a package
NEEDS_WORK = 1


def add_check_arguments(check: argparse.ArgumentParser) -> None:
    check.add_argument("-v", "--verbose", action="store_true",
                       help="list every line repair would change and every missing package")


def _venv() -> "os.PathLike[str]":
    from wsbuild.underlay.detect import find_venv_underlay  # lazy: off Tab completion and `--help`

    venv = find_venv_underlay(os.environ, sys.executable)
    if venv is None:
        raise UnderlayError(
            "no ROS underlay in the active virtualenv (no share/ament_index)",
            hint="pip install 'wsbuild[ros]' into the virtualenv, or source /opt/ros/jazzy/setup.bash",
        )
    return venv


def run_check(args: argparse.Namespace) -> int:
    """Report what `repair` would change, and ROS packages the wheels forgot to depend on:
    a summary, or every line with --verbose. Exit 0: nothing to do; NEEDS_WORK otherwise."""
    from wsbuild.underlay.missing import missing_packages  # lazy: off Tab completion and `--help`
    from wsbuild.underlay.repair import scan_underlay  # lazy: off Tab completion and `--help`

    venv = _venv()
    problems = scan_underlay(venv, use_cache=False)
    missing = missing_packages(venv)
    print(f"ROS underlay: {venv}")
    if not problems and not missing:
        print("  no problems found")
        return 0
    repairable = [p for p in problems if p.repairable]
    verbose = bool(getattr(args, "verbose", False))
    for problem in problems if verbose else [p for p in problems if not p.repairable]:
        kind = "repairable" if problem.repairable else "needs you"
        print(f"  {problem.path}:{problem.line}: [{kind}] {problem.text}\n    fix: {problem.fix}")
    if verbose:
        for item in missing:
            print(f"  missing: {item.name} (needed by {', '.join(item.required_by)}): "
                  f"pip install {item.requirement}")
    if repairable:
        files = len({p.path for p in repairable})
        print(f"  the wheels' build-machine paths: {plural(len(repairable), 'line')} in "
              f"{plural(files, 'file')} (wsbuild underlay repair rewrites them; wsbuild build "
              "does it by itself)")
    if missing:
        requirements = " ".join(item.requirement for item in missing)
        print(f"  ROS packages the underlay's CMake files need but nothing installed: "
              f"{len(missing)} (pip install {requirements})")
    if not verbose:
        print("every line: wsbuild underlay check --verbose")
    return NEEDS_WORK


def run_repair(args: argparse.Namespace) -> int:
    """Rewrite the wheels' broken CMake files inside the virtualenv (idempotent)."""
    from wsbuild.underlay.repair import repair_underlay  # lazy: off Tab completion and `--help`

    venv = _venv()
    changed = repair_underlay(venv)
    for path in changed:
        print(f"repaired {path}")
    print(f"{len(changed)} file(s) changed in {venv}")
    return 0
