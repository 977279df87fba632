"""Shared front half of every verb: find the workspace, discover, build the graph, select.

Prints nothing: the warnings of discovery come back in `Loaded.warnings` for the verb's one
output point (reporter.print_warnings).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wsbuild.build_types import KnownBuildTypes, get_build_type
from wsbuild.build_types.plugins import package_identifiers
from wsbuild.errors import ManifestError, WorkspaceError, WsbuildError
from wsbuild.verbs.arguments import Bases, bases_from_args, selection_from_args
from wsbuild.workspace.discover import discover_packages, expand_paths
from wsbuild.workspace.graph import Graph, build_graph
from wsbuild.workspace.model import Package
from wsbuild.workspace.root import Workspace, find_workspace_root, why_workspace_root
from wsbuild.workspace.selection import (
    Selection,
    SelectionOptions,
    ignored_packages,
    select_packages,
)

if TYPE_CHECKING:  # imported when the selection is given
    from wsbuild.verbs.cache_selection import CacheSelection
    from wsbuild.verbs.results import ResultSelection

#: under the build base: what each package.xml read gave (workspace/memo.py)
MANIFEST_MEMO = Path(".wsbuild") / "manifests.json"


@dataclass(frozen=True, slots=True)
class Loaded:
    """The workspace a verb works on: its packages, their graph, the selected ones."""

    workspace: Workspace
    packages: dict[str, Package]
    graph: Graph
    selected: list[str]
    warnings: tuple[str, ...]
    #: why the workspace is the one above the current directory ("" when it is not)
    chosen_because: str = ""


@dataclass(frozen=True, slots=True)
class LoadRequest:
    """Where the workspace is and which of its packages a verb takes: made of the command line
    once, at the verb's entry (`load_request_from_args`)."""

    #: -C/--workspace (None: found from the current directory)
    workspace_dir: str | None = None
    #: --base-paths (None: <workspace>/src), --paths (None: crawl the base paths)
    base_paths: tuple[str, ...] | None = None
    paths: tuple[str, ...] | None = None
    bases: Bases = Bases()
    selection: SelectionOptions = SelectionOptions()
    #: the result-based selection given (verbs/results.py), if any
    results: ResultSelection | None = None
    #: the cache-based selection given (verbs/cache_selection.py), if any
    cache: CacheSelection | None = None


def load_request_from_args(args: argparse.Namespace, *,
                           cache: CacheSelection | None = None) -> LoadRequest:
    """The LoadRequest of a verb's options (`cache`: the verb's own cache-based selection,
    judged by its build or test request; else one judged as a plain build and test would)."""
    from wsbuild.verbs.cache_selection import cache_selection_from_args  # lazy: off `test-result`
    from wsbuild.verbs.results import result_selection_from_args  # lazy: off `test-result`

    base_paths, paths = getattr(args, "base_paths", None), getattr(args, "paths", None)
    return LoadRequest(
        workspace_dir=getattr(args, "workspace_dir", None),
        base_paths=None if base_paths is None else tuple(base_paths),
        paths=None if paths is None else tuple(paths),
        bases=bases_from_args(args),
        selection=selection_from_args(args),
        results=result_selection_from_args(args),
        cache=cache or cache_selection_from_args(args),
    )


def workspace_root(workspace_dir: str | None) -> Path:
    """The workspace root: `-C/--workspace` if given, else found from the current directory."""
    if workspace_dir:
        root = Path(workspace_dir).absolute()
        if not root.is_dir():
            raise WorkspaceError("workspace directory does not exist", path=root,
                                 hint="check the -C/--workspace argument")
        return root
    return find_workspace_root(Path.cwd())


def load(request: LoadRequest, *, select: bool = True,
         warn: Callable[[Sequence[str]], None] | None = None,
         remember: bool = False, strict: bool = False, need_packages: bool = False) -> Loaded:
    """Discover the workspace `request` names and apply its selection.

    The discovery's warnings are in the result, and handed to `warn` (the verb's output point)
    as soon as they are known: before a selection error ends the verb. What each package.xml
    read gave is remembered under the build base and used by every verb; `remember` writes it
    down (the verbs a user runs again and again on an unchanged workspace; never a dry run or
    `clean`, which leave build/ as it is). `strict` (a build): a selected package's manifest
    problem that its build type's package.xml reader refuses is an error (`refuse_manifests`),
    said before any warning. `need_packages` (build, test): no package found is an error
    naming where it looked."""
    workspace = request.bases.workspace(workspace_root(request.workspace_dir))
    cwd = Path.cwd()
    base_paths = (
        [Path(p).absolute() for p in request.base_paths]
        if request.base_paths
        else workspace.default_base_paths()
    )
    paths = expand_paths(list(request.paths), cwd) if request.paths else []
    discovery = discover_packages(
        [workspace.build_base, workspace.install_base, workspace.log_base],
        base_paths=base_paths,
        paths=paths,
        environ=os.environ,
        known_build_types=KnownBuildTypes(),
        memo_file=workspace.build_base / MANIFEST_MEMO,
        remember=remember,
        identifiers=package_identifiers(),  # type: ignore[arg-type]
    )
    packages = discovery.packages
    if need_packages and not packages:
        _no_packages(workspace, paths or base_paths)
    from wsbuild.workspace.versions import check_version_constraints  # lazy: off `test-result`

    warnings = (*discovery.warnings, *check_version_constraints(packages))
    if warn is not None and not strict:
        warn(warnings)
    try:
        loaded = _selected(request, workspace, packages, warnings, select=select)
    except WsbuildError:
        if warn is not None and strict:
            warn(warnings)
        raise
    if strict:
        refuse_manifests(loaded.packages, loaded.selected)
        if warn is not None:
            warn(warnings)
    return loaded


def _no_packages(workspace: Workspace, searched: Sequence[Path]) -> None:
    """The error of a build or test that found no package: where it looked, and how to
    point it at one."""
    where = ", ".join(str(path) for path in searched)
    missing = [str(path) for path in searched if not path.exists()]
    hint = (f"{' and '.join(missing)} does not exist; " if missing else "") + (
        "a package is a directory holding a package.xml: create one in "
        f"{workspace.root / 'src'} with `wsbuild pkg create NAME`, or run wsbuild in the "
        "workspace that holds yours, or give --base-paths")
    raise WorkspaceError(f"no packages found in {where}; nothing to do, nothing written",
                         hint=hint)


def refuse_manifests(packages: Mapping[str, Package], selected: Sequence[str]) -> None:
    """The first manifest problem of a selected package that its build type's package.xml
    reader refuses (`BuildType.manifest_reader`: ament_cmake's catkin_pkg), as the error
    naming the file and line and the fix."""
    for name in selected:
        package = packages[name]
        if not package.refused:
            continue
        reader = get_build_type(package.build_type).manifest_reader
        if reader:
            line, problem, fix = package.refused[0]
            raise ManifestError(f"{problem}: {reader} refuses it", path=package.manifest,
                                line=line, hint=fix)


def _selected(request: LoadRequest, workspace: Workspace, packages: dict[str, Package],
              warnings: tuple[str, ...], *, select: bool) -> Loaded:
    """The selection of the discovered `packages`, and the graph it was made on."""
    options = request.selection if select else SelectionOptions()
    ignored = ignored_packages(options, packages)
    if ignored:
        packages = {n: p for n, p in packages.items() if n not in ignored}
    graph = build_graph(packages)
    if select:
        selected = select_packages(options, graph)
        if request.results is not None:
            from wsbuild.verbs.results import select_by_results  # lazy: off `test-result`

            selected = select_by_results(request.results, workspace.build_base, selected)
        if request.cache is not None:
            from wsbuild.verbs.cache_selection import select_by_cache  # lazy: off `test-result`

            selected = select_by_cache(request.cache,
                                       Selection(workspace, packages, graph, selected))
    else:
        selected = graph.topological_order()
    because = "" if request.workspace_dir else why_workspace_root(workspace.root, Path.cwd())
    return Loaded(workspace, packages, graph, selected, warnings, because)
