"""`wsbuild clean`: remove the build/, install/ and log/ entries of packages, then rewrite the
workspace setup scripts so that what remains still sources."""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import WorkspaceError
from wsbuild.prefix.layout import MERGED, PACKAGE_INDEX, read_install_layout
from wsbuild.reporter import print_warnings
from wsbuild.verbs.arguments import add_base_arguments
from wsbuild.words import plural

CLEAN_DOC = """Remove what builds left in build/, install/ and log/.

With package selection options, only the entries of those packages go: build/<pkg>,
install/<pkg> (or the package's files in a --merge-install prefix) and log/*/<pkg>;
install/setup.* are rewritten so the rest still sources. Without them, the whole build/,
install/ and log/ directories go. --build, --install and --log pick among the three
(default: all three). Lists what it will delete and asks first, unless -y.

Only entries inside the workspace's own build, install and log directories are ever
deleted: a base outside the workspace, a symbolic link leading out of one, or a directory
without colcon's COLCON_IGNORE marker is refused before anything is touched.

examples:
  wsbuild clean --packages-select my_driver -y
  wsbuild clean --packages-above my_msgs --build
  wsbuild clean --log

exit codes: 0 deleted (or nothing to delete, or declined), 2 refused or usage error
"""

#: what --build, --install and --log name (the bases themselves come from --*-base)
BUILD, INSTALL, LOG = "build", "install", "log"
#: colcon puts this marker in the build, install and log bases (and wsbuild does too)
BASE_MARKER = "COLCON_IGNORE"


def add_clean_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of `clean` besides the workspace and package selection ones."""
    what = parser.add_argument_group("what to remove (default: all three)")
    what.add_argument("--build", action="store_true", help="build/ entries")
    what.add_argument("--install", action="store_true", help="install/ entries")
    what.add_argument("--log", action="store_true", help="log/ entries")
    add_base_arguments(parser.add_argument_group("where"), log_secondary=False)
    parser.add_argument("-y", "--yes", action="store_true",
                        help="delete without asking (needed when stdin is not a terminal)")


@dataclass(frozen=True, slots=True)
class Removal:
    """One directory or file to delete, inside one of the workspace's bases."""

    path: Path
    base: Path


@dataclass(frozen=True, slots=True)
class CleanPlan:
    """What `wsbuild clean` removes, and whether install/'s setup scripts are rewritten."""

    removals: tuple[Removal, ...]
    #: install/ loses packages but stays: its setup scripts must be rewritten
    rewrite_install: bool
    merged: bool


def _inside(path: Path, parent: Path) -> bool:
    return path == parent or parent in path.parents


def _real(path: Path) -> Path:
    return Path(os.path.realpath(path))


def check_base(base: Path, root: Path, sources: Sequence[Path]) -> None:
    """Refuse a base that is not the workspace's own: outside it, a symbolic link, holding
    sources, or an existing directory colcon/wsbuild did not mark as one of its bases."""
    if base.is_symlink():
        raise WorkspaceError("refusing to clean through a symbolic link", path=base,
                             hint="remove the link or its target by hand")
    real, real_root = _real(base), _real(root)
    if real_root not in real.parents:
        raise WorkspaceError("refusing to clean a directory outside the workspace", path=base,
                             hint=f"bases must be inside {root}; delete it by hand")
    for source in sources:
        if _inside(_real(source), real):
            raise WorkspaceError("refusing to clean a directory that holds sources", path=base,
                                 hint=f"it contains {source}")
    if base.is_dir() and not (base / BASE_MARKER).exists():
        raise WorkspaceError(
            f"refusing to clean a directory without the {BASE_MARKER} marker", path=base,
            hint="colcon and wsbuild put one in every build, install and log directory; "
            "check --build-base/--install-base/--log-base, or delete it by hand")


def check_removal(removal: Removal) -> None:
    """Refuse an entry reached through, or being, a symbolic link that leads out of its base."""
    if removal.path == removal.base:
        return  # a whole base: check_base looked at it
    base = _real(removal.base)
    if not _inside(_real(removal.path.parent), base):
        raise WorkspaceError("refusing to clean: a symbolic link on the way leads out of "
                             f"{removal.base}", path=removal.path)
    if removal.path.is_symlink() and not _inside(_real(removal.path), base):
        raise WorkspaceError(f"refusing to clean a symbolic link leading out of {removal.base}",
                             path=removal.path, hint=f"it points to {_real(removal.path)}")


def plan_clean(root: Path, bases: dict[str, Path], kinds: Sequence[str],
               packages: Sequence[str] | None, sources: Sequence[Path]) -> CleanPlan:
    """What `clean` deletes from the `kinds` of `bases`: whole bases (`packages` None) or the
    packages' entries. Raises before anything is touched when an entry is not safe to delete."""
    chosen = {kind: bases[kind] for kind in kinds}
    for base in chosen.values():
        check_base(base, root, sources)
    install = bases[INSTALL]
    merged = read_install_layout(install) == MERGED
    removals: list[Removal] = []
    if packages is None:
        removals = [Removal(base, base) for base in chosen.values() if os.path.lexists(base)]
    else:
        if BUILD in chosen:
            removals += [Removal(bases[BUILD] / name, bases[BUILD]) for name in packages
                         if os.path.lexists(bases[BUILD] / name)]
        if INSTALL in chosen and install.is_dir():
            # (a merged package's record in build/ is read here, before anything is deleted)
            removals += _install_entries(install, bases[BUILD], packages, merged)
        if LOG in chosen:
            removals += _log_entries(bases[LOG], packages)
    for removal in removals:
        check_removal(removal)
    rewrite = packages is not None and any(r.base == install for r in removals)
    return CleanPlan(tuple(removals), rewrite_install=rewrite, merged=merged)


def _install_entries(install: Path, build: Path, packages: Sequence[str],
                     merged: bool) -> list[Removal]:
    from wsbuild.prefix.stage import MERGED_RECORD  # lazy: off `clean` and Tab completion

    if not merged:
        return [Removal(install / name, install) for name in packages
                if os.path.lexists(install / name)]
    # a merged prefix is shared: a package's files are those its last build recorded
    removals: list[Removal] = []
    for name in packages:
        if not (install / PACKAGE_INDEX / name).exists():
            continue
        record = build / name / MERGED_RECORD
        if not record.is_file():
            raise WorkspaceError(
                f"cannot tell which files of the merged install belong to '{name}': the "
                "record of its last build is gone", path=record,
                hint="clean the whole install/ instead: wsbuild clean --install")
        for rel in record.read_text().splitlines():
            if rel and os.path.lexists(install / rel):
                removals.append(Removal(install / rel, install))
    return removals


def _log_entries(log: Path, packages: Sequence[str]) -> list[Removal]:
    if not log.is_dir():
        return []
    wanted = set(packages)
    removals = []
    for run in sorted(log.iterdir()):
        # latest, latest_build… are links to runs: each run is visited once, as itself
        if run.is_symlink() or not run.is_dir():
            continue
        removals += [Removal(run / name, log) for name in sorted(wanted)
                     if os.path.lexists(run / name)]
    return removals


def remove(plan: CleanPlan) -> None:
    """Delete the plan's entries (never following a symbolic link), then empty directories
    a merged package leaves behind."""
    emptied: set[Path] = set()
    for removal in plan.removals:
        path = removal.path
        if path.is_symlink() or not path.is_dir():
            path.unlink(missing_ok=True)
        else:
            shutil.rmtree(path)
        if removal.path != removal.base:
            emptied.add(path.parent)
    if plan.merged:
        for directory in sorted(emptied, key=lambda p: len(p.parts), reverse=True):
            _remove_empty_parents(directory, _base_of(plan, directory))


def _base_of(plan: CleanPlan, path: Path) -> Path:
    return next(r.base for r in plan.removals if _inside(path, r.base))


def _remove_empty_parents(directory: Path, stop: Path) -> None:
    while directory != stop and directory.is_dir() and not any(directory.iterdir()):
        directory.rmdir()
        directory = directory.parent


def rewrite_setup_scripts(install: Path, merged: bool) -> None:
    """install/local_setup.* for the packages that remain; setup.* (the underlay chain the
    build wrote) stays as it is."""
    from wsbuild.prefix import write_workspace_scripts  # lazy: off `clean` and Tab completion

    write_workspace_scripts(install, merged=merged, underlays=None)


# ---------------------------------------------------------------------------- the verb


def _relative(path: Path, root: Path) -> str:
    try:
        text = str(path.relative_to(root))
    except ValueError:
        text = str(path)
    return text + ("/" if path.is_dir() and not path.is_symlink() else "")


def confirm(question: str, *, ask: Callable[[str], str] = input) -> bool:
    try:
        answer = ask(question)
    except EOFError:
        return False
    return answer.strip().lower() in ("y", "yes")


def deletion_confirmed(yes_option: str) -> bool:
    """Ask on the terminal before deleting what was just listed; without a terminal, refuse
    (a script passes `yes_option`)."""
    if sys.stdin is None or not sys.stdin.isatty():
        raise WorkspaceError("refusing to delete without asking: stdin is not a terminal",
                             hint=f"pass {yes_option} to delete without asking")
    sys.stdout.flush()
    if confirm("Delete these? [y/N] "):
        return True
    print("nothing deleted")
    return False


def run_clean(args: argparse.Namespace) -> int:
    """Remove build/, install/ and log/ entries of the selected packages (default: all)."""
    from wsbuild.engine.lock import workspace_lock  # lazy: off Tab completion and `--help`
    from wsbuild.verbs.load import (
        load, load_request_from_args, workspace_root)  # lazy: off Tab completion
    from wsbuild.workspace.selection import SelectionOptions  # lazy: off Tab completion

    request = load_request_from_args(args)
    kinds = [k for k in (BUILD, INSTALL, LOG) if getattr(args, k)] or [BUILD, INSTALL, LOG]
    selected = request.selection != SelectionOptions() or bool(request.paths)
    if selected:
        loaded = load(request, warn=print_warnings)
        workspace = loaded.workspace
        packages: list[str] | None = loaded.selected
        sources = [p.path for p in loaded.packages.values()]
    else:
        workspace = request.bases.workspace(workspace_root(request.workspace_dir))
        packages = None
        sources = [Path(p).absolute() for p in request.base_paths] if request.base_paths else (
            workspace.default_base_paths())
    root = workspace.root
    bases = {BUILD: workspace.build_base, INSTALL: workspace.install_base,
             LOG: workspace.log_base}
    plan = plan_clean(root, bases, kinds, packages, sources)
    if not plan.removals:
        print("nothing to clean")
        return 0
    print(f"wsbuild clean will delete {plural(len(plan.removals), 'entry', 'entries')}:")
    for removal in plan.removals:
        print(f"  {_relative(removal.path, root)}")
    if not args.yes and not deletion_confirmed("-y"):
        return 0
    # not while a build writes into what is being deleted (a build creates build/ first);
    # what changed meanwhile is planned again, and only what was listed goes
    locked = workspace.build_base.is_dir()
    with (workspace_lock(workspace.build_base, wait=True, on_wait=_waiting) if locked
          else contextlib.nullcontext()):
        listed = set(plan.removals)
        again = plan_clean(root, bases, kinds, packages, sources)
        plan = CleanPlan(tuple(r for r in again.removals if r in listed),
                         again.rewrite_install, again.merged)
        remove(plan)
        if plan.rewrite_install and workspace.install_base.is_dir():
            rewrite_setup_scripts(workspace.install_base, plan.merged)
    print(f"deleted {plural(len(plan.removals), 'entry', 'entries')}")
    return 0


def _waiting(text: str) -> None:
    print(f"wsbuild: {text}", file=sys.stderr)

