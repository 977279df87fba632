"""Shared front half of every verb: find the workspace, discover, build the graph, select.

Prints nothing: the warnings of discovery come back in `Loaded.warnings` for the verb's one
output point (report.print_warnings).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from wsbuild.build_types import KnownBuildTypes
from wsbuild.verbs.arguments import selection_from_args, workspace_from_args
from wsbuild.workspace.discover import discover_packages, expand_paths
from wsbuild.workspace.graph import Graph, build_graph
from wsbuild.workspace.model import Package
from wsbuild.workspace.root import Workspace
from wsbuild.workspace.selection import (
    SelectionOptions,
    ignored_packages,
    select_packages,
)


#: under the build base: what each package.xml read gave (workspace/memo.py)
MANIFEST_MEMO = Path(".wsbuild") / "manifests.json"


@dataclass(frozen=True, slots=True)
class Loaded:
    workspace: Workspace
    packages: dict[str, Package]
    graph: Graph
    selected: list[str]
    warnings: tuple[str, ...]


def workspace_root(args: argparse.Namespace) -> Path:
    """The workspace root: `-C/--workspace` if given, else found from the current directory."""
    from wsbuild.workspace.root import find_workspace_root

    if args.workspace_dir:
        root = Path(args.workspace_dir).absolute()
        if not root.is_dir():
            from wsbuild.errors import WorkspaceError

            raise WorkspaceError("workspace directory does not exist", path=root,
                                 hint="check the -C/--workspace argument")
        return root
    return find_workspace_root(Path.cwd())


def load(args: argparse.Namespace, *, select: bool = True,
         warn: Callable[[Sequence[str]], None] | None = None,
         remember: bool = False) -> Loaded:
    """Discover the workspace named by `args` and apply the selection options.

    The discovery's warnings are in the result, and handed to `warn` (the verb's output point)
    as soon as they are known: before a selection error ends the verb. What each package.xml
    read gave is remembered under the build base and used by every verb; `remember` writes it
    down (the verbs a user runs again and again on an unchanged workspace; never a dry run or
    `clean`, which leave build/ as it is)."""
    workspace = workspace_from_args(args, workspace_root(args))
    cwd = Path.cwd()
    base_paths = (
        [Path(p).absolute() for p in args.base_paths]
        if args.base_paths
        else workspace.default_base_paths()
    )
    paths = expand_paths(args.paths, cwd) if args.paths else []
    discovery = discover_packages(
        [workspace.build_base, workspace.install_base, workspace.log_base],
        base_paths=base_paths,
        paths=paths,
        environ=os.environ,
        known_build_types=KnownBuildTypes(),
        memo_file=workspace.build_base / MANIFEST_MEMO,
        remember=remember,
    )
    packages = discovery.packages
    from wsbuild.workspace.versions import check_version_constraints

    warnings = (*discovery.warnings, *check_version_constraints(packages))
    if warn is not None:
        warn(warnings)
    options = selection_from_args(args) if select else SelectionOptions()
    ignored = ignored_packages(options, packages)
    if ignored:
        packages = {n: p for n, p in packages.items() if n not in ignored}
    graph = build_graph(packages)
    if select:
        from wsbuild.verbs.results import select_by_results

        selected = select_by_results(args, workspace.build_base, select_packages(options, graph))
        from wsbuild.verbs.cache_selection import cache_selection_given, select_by_cache

        if cache_selection_given(args):
            from wsbuild.workspace.selection import Selection

            selected = select_by_cache(args, Selection(workspace, packages, graph, selected))
    else:
        selected = graph.topological_order()
    return Loaded(workspace, packages, graph, selected, warnings)
